"""Property-based tests (Hypothesis) of :func:`pfpeople.config.config_from_mapping` on random tables.

Random documents built from the real keys with values of every TOML type. Invariant: a config is built or
``ValueError`` / ``TypeError`` is raised (the documented errors; ``load_config`` turns both into a message
naming the file), and a built config round-trips through ``to_dict``. Deterministic: ``derandomize=True``.
"""

from __future__ import annotations

from typing import Any

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from pfpeople.config import BagConfig, config_from_mapping

SETTINGS = settings(
    max_examples=60, derandomize=True, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow]
)

_scalar = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**12), max_value=10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["", "/scan", "grid", "particle", "leg", "topic", "preceding", "laser", "x"]),
)
_value = (
    _scalar | st.lists(_scalar, max_size=3) | st.dictionaries(st.sampled_from(["a", "ppv", "x"]), _scalar, max_size=2)
)

_KEYS = {
    "frames": ["driver", "grid_frame", "base_frame", "time_source", "sync_tolerance_s", "max_pending_frames", "bad"],
    "grid": ["nx", "ny", "resolution", "x0", "y0"],
    "filter": ["kind", "form", "initial", "n_particles", "seed"],
    "odometry": ["topic"],
    "tf": ["topics"],
}
_DET_KEYS = ["name", "kind", "topic", "frame", "assign", "model", "params"]
_GOOD = {
    "driver": st.just("/scan"),
    "nx": st.integers(min_value=-2, max_value=5000),
    "ny": st.integers(min_value=-2, max_value=5000),
    "resolution": st.floats(min_value=-1.0, max_value=2.0) | st.just(1e-300),
    "n_particles": st.integers(min_value=-1, max_value=10**10),
    "kind": st.sampled_from(["grid", "particle", "leg", "boosted", "topic", "hog"]),
    "name": st.sampled_from(["a", "b"]),
    "topic": st.sampled_from(["/scan", "/people"]),
    "model": st.fixed_dictionaries({}, optional={"ppv": st.floats(0, 1), "fnr": st.floats(0, 1)}),
}


def _entry(key: str) -> st.SearchStrategy[Any]:
    return (_GOOD[key] | _value) if key in _GOOD else _value


@st.composite
def documents(draw: st.DrawFn) -> dict[str, Any]:
    doc: dict[str, Any] = {}
    for table, keys in _KEYS.items():
        if draw(st.booleans()):
            chosen = draw(st.lists(st.sampled_from(keys), unique=True, max_size=len(keys)))
            doc[table] = {k: draw(_entry(k)) for k in chosen}
    if "frames" in doc and draw(st.booleans()):
        doc["frames"]["driver"] = "/scan"
    dets: list[dict[str, Any]] = []
    for _ in range(draw(st.integers(min_value=0, max_value=2))):
        chosen = draw(st.lists(st.sampled_from(_DET_KEYS), unique=True, max_size=len(_DET_KEYS)))
        dets.append({k: draw(_entry(k)) for k in chosen})
    keep_empty: bool = draw(st.booleans())
    if dets or keep_empty:
        doc["detectors"] = dets
    if draw(st.booleans()):
        doc["mounts"] = draw(st.dictionaries(st.sampled_from(["laser", "cam"]), _value, max_size=2))
    return doc


@SETTINGS
@given(documents())
@example({"frames": {"driver": "/scan"}, "detectors": [{"name": "a", "kind": "leg", "topic": "/scan"}]})
@example(
    {
        "frames": {"driver": "/scan"},
        "grid": {"resolution": 1e-300},
        "detectors": [{"name": "a", "kind": "leg", "topic": "/s"}],
    }
)
def test_random_configs_build_or_raise_the_documented_errors(doc: dict[str, Any]) -> None:
    try:
        cfg = config_from_mapping(doc)
    except (ValueError, TypeError):
        return
    assert isinstance(cfg, BagConfig)
    assert config_from_mapping(cfg.to_dict()) == cfg
