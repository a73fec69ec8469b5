"""Optional dependencies: the parts of pfpeople that need an extra say which one when it is missing.

``pip install 'pfpeople[batch]'`` adds Dask (``pfpeople batch``, ``pfpeople-eval sweep``); ``pip install
'pfpeople[eval]'`` adds py-motmetrics (the CLEAR-MOT scores of ``pfpeople-eval``); ``make setup`` installs both.
``pip install 'pfpeople[train]'`` adds PyTorch (training the learned detector: ``pfpeople train-detector --kind
learned``); running a trained model needs none of them.
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["EXTRAS", "MissingExtraError", "require"]

#: The module each extra provides, by the extra's name.
EXTRAS: dict[str, str] = {"batch": "distributed", "eval": "motmetrics", "train": "torch"}


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message names the extra that provides it."""


def require(extra: str, what: str) -> ModuleType:
    """Import the module of ``extra`` (:data:`EXTRAS`), or raise :class:`MissingExtraError` naming it.

    Parameters
    ----------
    extra : str
        The extra's name, a key of :data:`EXTRAS`.
    what : str
        What needs it, for the message (e.g. ``"pfpeople batch"``).

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    MissingExtraError
        If the module cannot be imported.
    """
    module = EXTRAS[extra]
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtraError(
            f"{what} needs the optional dependency {module!r} ({exc}); install it with: pip install 'pfpeople[{extra}]'"
        ) from exc
