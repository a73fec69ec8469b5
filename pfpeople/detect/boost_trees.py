"""The boosted classifier's raw scores without OpenCV's ``predict``: its trees walked by a compiled loop.

:class:`BoostTrees` holds the trees of an OpenCV ``cv2.ml.Boost`` model file, read once with OpenCV's own
``cv2.FileStorage`` (the parser ``cv2.ml.Boost.load`` uses) and rebuilt as ``DTreesImpl::readTree`` does (the
nodes of a tree in pre-order, each split node followed by its left then its right subtree). A row's score is
what ``predict(X, flags=DTREES_PREDICT_SUM | STAT_MODEL_RAW_OUTPUT)`` returns: in every tree, from its root, a
split node sends the row left when its float32 feature value is ``<=`` the split's float32 threshold (so NaN
goes right; the missing-value marker ``FLT_MAX`` is replaced by the model's ``missing_subst`` first), and the
leaves' float64 values are summed from 0.0 in the trees' order, then rounded to float32.

:func:`load_trees` accepts only the models this walk reproduces (ordered features, identity ``var_idx``, one
``le`` split per split node, a ``missing_subst`` for every feature) and checks the walk against OpenCV's scores
on a fixed sample that takes both branches of every split (the thresholds, their float32 neighbours, NaN, the
infinities, 0 and ``FLT_MAX``); any other model, or any difference, gives None and the caller keeps OpenCV's
``predict``. The walk is compiled (:func:`tree_sums`, numba, :mod:`gridbridge.jit` scope ``"pfpeople"``) with a
numpy twin (:func:`tree_sums_numpy`) giving the same floats.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from gridbridge import jit as _jit
from gridbridge.jit import jit as njit

__all__ = ["BoostTrees", "check_model_values", "load_trees", "tree_sums", "tree_sums_numpy"]

#: OpenCV's missing-value marker of a sample (``TrainData::missingValue()``: ``FLT_MAX``).
_MISSING = np.float32(np.finfo(np.float32).max)


@dataclass(frozen=True, kw_only=True, eq=False)
class BoostTrees:
    """The trees of a boosted model, each padded to a perfect binary tree of the model's largest depth ``D``.

    A leaf above depth ``D`` is repeated under a split that sends every row to it (both children the same), so
    every row takes ``D`` steps in every tree: node ``k``'s children are ``2 k + 1`` (left) and ``2 k + 2``.

    Attributes
    ----------
    var : ndarray, shape (T, 2**D - 1), intp
        Feature index of every split, by tree (in the model's order) and node.
    threshold : ndarray, shape (T, 2**D - 1), float32
        The split's threshold: a row goes left when its value is ``<=``.
    leaf : ndarray, shape (T, 2**D), float64
        The value of every leaf, left to right.
    missing : ndarray, shape (F,), float32
        The value replacing ``FLT_MAX`` in feature ``f``.
    """

    var: NDArray[np.intp]
    threshold: NDArray[np.float32]
    leaf: NDArray[np.float64]
    missing: NDArray[np.float32]

    def scores(self, X: NDArray[np.float32]) -> NDArray[np.float64]:
        """The raw scores ``(n,)`` of the rows of ``X`` ``(n, F)`` (float32 features), as float64: the compiled walk
        when ``gridbridge.jit.enabled("pfpeople")``, else its numpy twin."""
        walk = tree_sums if _jit.enabled("pfpeople") else tree_sums_numpy
        out: NDArray[np.float64] = walk(
            np.ascontiguousarray(X, dtype=np.float32), self.var, self.threshold, self.leaf, self.missing
        )
        return out


@njit
def tree_sums(
    X: NDArray[np.float32],
    var: NDArray[np.intp],
    threshold: NDArray[np.float32],
    leaf: NDArray[np.float64],
    missing: NDArray[np.float32],
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    """The raw boosted scores of the rows of ``X``, shape (n, F) float32 (the arrays of :class:`BoostTrees`).

    Returns
    -------
    ndarray, shape (n,)
        The float64 sum of every row's leaf values over the trees in order, from 0.0, rounded to float32 and
        returned as float64 (OpenCV's float result).
    """
    n, n_trees, n_split = X.shape[0], var.shape[0], var.shape[1]
    out = np.empty(n)
    for i in range(n):
        total = 0.0
        for t in range(n_trees):
            k = 0
            while k < n_split:
                f = var[t, k]
                v = X[i, f]
                if v == _MISSING:
                    v = missing[f]
                k = 2 * k + 1 + int(not v <= threshold[t, k])
            total += leaf[t, k - n_split]
        out[i] = np.float64(np.float32(total))
    return out


def tree_sums_numpy(
    X: NDArray[np.float32],
    var: NDArray[np.intp],
    threshold: NDArray[np.float32],
    leaf: NDArray[np.float64],
    missing: NDArray[np.float32],
) -> NDArray[np.float64]:
    """The numpy twin of :func:`tree_sums` (the same arguments and floats): every tree walked for all rows at
    once, one level a step, and its leaf values added to the rows' float64 sums in the trees' order."""
    rows = np.arange(X.shape[0])
    n_split = var.shape[1]
    total = np.zeros(X.shape[0])
    for t in range(var.shape[0]):
        k = np.zeros(X.shape[0], dtype=np.intp)
        while k.size and k[0] < n_split:
            f = var[t, k]
            v = X[rows, f]
            v = np.where(v == _MISSING, missing[f], v)
            k = 2 * k + 1 + ~(v <= threshold[t, k])
        total += leaf[t, k - n_split]
    return total.astype(np.float32).astype(np.float64)


def _read_tree(nodes: Any, n_features: int, out: dict[str, list[Any]]) -> int | None:
    """Append the nodes of one tree (a ``cv2.FileNode`` sequence) to ``out`` as ``DTreesImpl::readTree`` links
    them (pre-order, left child first); the root's index, or None for a split this walk does not reproduce."""
    root, parent = -1, -1
    for k in range(nodes.size()):
        fn = nodes.at(k)
        idx = len(out["value"])
        out["value"].append(fn.getNode("value").real())
        out["left"].append(-1)
        out["right"].append(-1)
        out["parent"].append(parent)
        splits = fn.getNode("splits")
        is_split = not splits.empty() and splits.size() > 0
        var, thr = -1, 0.0
        if is_split:
            sp = splits.at(0)
            if sp.getNode("le").empty():
                return None  # a "gt" (inversed) or categorical split
            var, thr = int(sp.getNode("var").real()), sp.getNode("le").real()
            if not 0 <= var < n_features:
                return None
        out["var"].append(var)
        out["threshold"].append(thr)
        if parent < 0:
            root = idx
        elif out["left"][parent] < 0:
            out["left"][parent] = idx
        else:
            out["right"][parent] = idx
        if is_split:
            parent = idx
        else:
            while parent >= 0 and out["right"][parent] >= 0:
                parent = out["parent"][parent]
    return root if root >= 0 else None


def _ints(node: Any) -> list[int]:
    """The integers of a ``cv2.FileNode`` sequence (or one number)."""
    if node.isSeq():
        return [int(node.at(i).real()) for i in range(node.size())]
    return [int(node.real())]


def _read_model(path: Path, n_features: int) -> BoostTrees | None:
    """The trees of the model file ``path``, or None when the model is not one this walk reproduces."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        m = fs.getNode("opencv_ml_boost")
        if m.empty() or int(m.getNode("var_count").real()) != n_features:
            return None
        var_idx, var_type = m.getNode("var_idx"), m.getNode("var_type")
        if not var_idx.empty() and _ints(var_idx) != list(range(n_features)):
            return None
        if var_type.empty() or any(_ints(var_type)[:n_features]):
            return None  # a categorical feature
        subst = m.getNode("missing_subst")
        if subst.empty() or subst.size() < n_features:
            return None
        missing = np.array([subst.at(i).real() for i in range(n_features)], dtype=np.float32)
        trees = m.getNode("trees")
        out: dict[str, list[Any]] = {k: [] for k in ("value", "left", "right", "parent", "var", "threshold")}
        roots = []
        for t in range(trees.size()):
            root = _read_tree(trees.at(t).getNode("nodes"), n_features, out)
            if root is None:
                return None
            roots.append(root)
    finally:
        fs.release()
    if not roots:
        return None
    return _perfect(roots, out, missing)


def _depth(node: int, left: list[int], right: list[int]) -> int:
    """The number of splits on the longest path from ``node`` to a leaf."""
    if left[node] < 0:
        return 0
    return 1 + max(_depth(left[node], left, right), _depth(right[node], left, right))


def _perfect(roots: list[int], nodes: dict[str, list[Any]], missing: NDArray[np.float32]) -> BoostTrees | None:
    """The linked trees of :func:`_read_tree` padded to perfect trees of their largest depth (:class:`BoostTrees`);
    None for a depth above 12."""
    left, right = nodes["left"], nodes["right"]
    depth = max(_depth(r, left, right) for r in roots)
    if depth > 12:
        return None
    n_split = 2**depth - 1
    var = np.zeros((len(roots), n_split), dtype=np.intp)
    thr = np.zeros((len(roots), n_split), dtype=np.float32)
    leaf = np.zeros((len(roots), n_split + 1))
    for t, root in enumerate(roots):
        todo = [(root, 0)]
        while todo:
            node, k = todo.pop()
            if k >= n_split:
                leaf[t, k - n_split] = nodes["value"][node]
            elif left[node] < 0:  # a leaf above the bottom: both children lead to it
                todo += [(node, 2 * k + 1), (node, 2 * k + 2)]
            else:
                var[t, k], thr[t, k] = nodes["var"][node], nodes["threshold"][node]
                todo += [(left[node], 2 * k + 1), (right[node], 2 * k + 2)]
    return BoostTrees(var=var, threshold=thr, leaf=leaf, missing=missing)


def check_sample(trees: BoostTrees, n_features: int, *, rows: int = 512) -> NDArray[np.float32]:
    """A fixed sample ``(rows, F)`` of float32 features taking both branches of the splits: each value drawn
    (seeded) from the thresholds of its feature, their float32 neighbours, and 0, ``FLT_MAX``, NaN and the
    infinities."""
    rng = np.random.default_rng(20261202)
    special = np.array([0.0, _MISSING, np.nan, np.inf, -np.inf], dtype=np.float32)
    X = np.empty((rows, n_features), dtype=np.float32)
    for f in range(n_features):
        thr = np.unique(trees.threshold[trees.var == f])
        pool = np.concatenate(
            (thr, np.nextafter(thr, np.float32(np.inf)), np.nextafter(thr, np.float32(-np.inf)), special)
        )
        X[:, f] = rng.choice(pool, size=rows)
    return X


def _bad_value(m: Any) -> str | None:
    """Where the model node ``m`` (``opencv_ml_boost``) holds a value no prediction can use, or None: a leaf or node
    value that is not finite (the sum of every row would be NaN or infinite), a NaN split threshold or missing-value
    substitute (every row would go one way)."""
    subst = m.getNode("missing_subst")
    for i in range(subst.size() if subst.isSeq() else 0):
        if math.isnan(subst.at(i).real()):
            return f"missing_subst[{i}] is nan"
    trees = m.getNode("trees")
    for t in range(trees.size()):
        nodes = trees.at(t).getNode("nodes")
        for k in range(nodes.size()):
            fn = nodes.at(k)
            value = fn.getNode("value").real()
            if not math.isfinite(value):
                return f"tree {t} node {k} has the value {value!r}"
            splits = fn.getNode("splits")
            for j in range(splits.size() if not splits.empty() else 0):
                sp = splits.at(j)
                for key in ("le", "gt"):
                    if not sp.getNode(key).empty() and math.isnan(sp.getNode(key).real()):
                        return f"tree {t} node {k} splits at {key} nan"
    return None


def check_model_values(path: Path) -> None:
    """Refuse a boosted model file whose trees hold a non-finite value (see :func:`_bad_value`): it loads in OpenCV,
    and the detector would then score every segment NaN and find nobody, silently.

    Raises
    ------
    ValueError
        Naming the file, the tree and the node.
    """
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        bad = _bad_value(fs.getNode("opencv_ml_boost"))
    finally:
        fs.release()
    if bad is not None:
        raise ValueError(
            f"boosted model file {str(path)!r} is damaged: {bad}; retrain it (`pfpeople train-detector`) or use the "
            "shipped model"
        )


def load_trees(path: Path, boost: Any, n_features: int) -> BoostTrees | None:
    """The trees of the OpenCV Boost model file ``path`` (loaded as ``boost``) with ``n_features`` features, or None
    when this walk does not reproduce the model or disagrees with ``boost.predict`` on :func:`check_sample` (both
    the numpy twin and, when it is enabled, the compiled walk are checked, bit for bit)."""
    try:
        trees = _read_model(path, n_features)
    except cv2.error:
        return None
    if trees is None:
        return None
    X = check_sample(trees, n_features)
    _, ref = boost.predict(X, flags=cv2.ml.DTREES_PREDICT_SUM | cv2.ml.STAT_MODEL_RAW_OUTPUT)
    expect = np.asarray(ref, dtype=np.float64).reshape(-1)
    for on in (True, False) if _jit.enabled("pfpeople") else (False,):
        with _jit.override(on, "pfpeople"):
            got = trees.scores(X)
        if got.tobytes() != expect.tobytes():
            return None
    return trees
