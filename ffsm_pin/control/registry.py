"""Controller types by name: built-in, from installed packages, or a user's class.

``[controller] type`` is one of

* a built-in name (:data:`BUILTIN`);
* a name another installed package registers in the entry-point group
  ``ffsm_pin.controllers`` (``name = "package.module:Class"`` in its ``pyproject.toml``);
* ``"file.py:Class"``: a class in a Python file, the path relative to the scenario file;
* ``"package.module:Class"``: a class in an importable module.

Anything that cannot be resolved raises :class:`~ffsm_pin.errors.ControllerLoadError` naming
the type and the valid choices.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from importlib.metadata import entry_points
from pathlib import Path

from ..errors import ControllerLoadError, choices_text, did_you_mean
from .adaptive_ct import AdaptiveComputedTorque
from .gjm_ct import GjmComputedTorque
from .lu_jia import LuJiaController

ENTRY_POINT_GROUP = "ffsm_pin.controllers"
DEFAULT_TYPE = "lu-jia"
BUILTIN: dict[str, type] = {
    "lu-jia": LuJiaController,
    "gjm-ct": GjmComputedTorque,
    "adaptive-ct": AdaptiveComputedTorque,
}


def installed_types() -> dict[str, object]:
    """Controller types registered by installed packages (name -> entry point)."""
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def known_types() -> tuple[str, ...]:
    """Every controller type name that resolves without a path: built-in, then installed."""
    return tuple(BUILTIN) + tuple(sorted(set(installed_types()) - set(BUILTIN)))


def controller_class(kind: str, base_dir: str | Path | None = None) -> type:
    """The class of controller type ``kind`` (see the module docstring).

    Parameters
    ----------
    kind : str
        A type name or ``"file.py:Class"`` / ``"package.module:Class"``.
    base_dir : str or Path or None
        Folder a relative ``file.py`` is looked up in (the scenario file's folder); the
        working directory when None.

    Returns
    -------
    type
        The controller class.
    """
    if kind in BUILTIN:
        return BUILTIN[kind]
    installed = installed_types()
    if kind in installed:
        try:
            cls = installed[kind].load()  # type: ignore[attr-defined]
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # a broken plug-in (sys.exit too) is bad input
            raise ControllerLoadError(
                f"controller.type {kind!r}: its entry point could not be loaded "
                f"({type(exc).__name__}: {exc})"
            ) from exc
        return _checked(kind, cls)
    if ":" not in kind:
        raise ControllerLoadError(
            f"controller.type {kind!r} unknown{did_you_mean(kind, known_types())}; valid "
            f"choices: {choices_text(known_types())}, or 'file.py:Class' / "
            "'package.module:Class' for a user's controller"
        )
    where, _, name = kind.rpartition(":")
    if not name.isidentifier() or not where:
        raise ControllerLoadError(
            f"controller.type {kind!r}: expected 'file.py:Class' or 'package.module:Class'"
        )
    module = _from_file(kind, where, base_dir) if where.endswith(".py") else _import(kind, where)
    cls = getattr(module, name, None)
    if cls is None:
        found = sorted(k for k, v in vars(module).items() if isinstance(v, type))
        raise ControllerLoadError(
            f"controller.type {kind!r}: no class {name!r} in {where}"
            f"{did_you_mean(name, found)}; classes there: {choices_text(found) or 'none'}"
        )
    return _checked(kind, cls)


def controller_label(kind: str) -> str:
    """A short name for controller type ``kind`` (tables, legends, folder names): a built-in
    or installed type's name, a user class's name (``"path/my_ctrl.py:MyController"`` ->
    ``"MyController"``)."""
    return kind.rpartition(":")[2] if ":" in kind else kind


def resolved_type(kind: str, base_dir: str | Path | None) -> str:
    """``kind`` with a relative ``file.py`` made absolute (for the saved scenario.toml).

    Parameters
    ----------
    kind : str
        A controller type.
    base_dir : str or Path or None
        Folder a relative ``file.py`` is relative to (the scenario file's).

    Returns
    -------
    str
        ``kind``, its file made absolute.
    """
    where, sep, name = kind.rpartition(":")
    if not sep or not where.endswith(".py") or kind in BUILTIN:
        return kind
    path = Path(where)
    if not path.is_absolute():
        path = Path(base_dir or ".") / path
    return f"{path.resolve()}:{name}"


def _checked(kind: str, cls: object) -> type:
    if not isinstance(cls, type):
        raise ControllerLoadError(f"controller.type {kind!r} is not a class ({type(cls).__name__})")
    if not callable(getattr(cls, "step", None)):
        raise ControllerLoadError(
            f"controller.type {kind!r}: class {cls.__name__} has no step(meas) method "
            "(docs/controllers.md, the controller interface)"
        )
    return cls


def _from_file(kind: str, file: str, base_dir: str | Path | None):
    path = Path(file)
    if not path.is_absolute():
        path = Path(base_dir or ".") / path
    path = path.resolve()
    if not path.is_file():
        raise ControllerLoadError(f"controller.type {kind!r}: file not found: {path}")
    # one module per file (the hash keeps two files of the same name apart)
    tag = hashlib.sha1(str(path).encode()).hexdigest()[:10]
    mod_name = f"ffsm_pin_user_controller_{path.stem}_{tag}"
    if mod_name in sys.modules:
        return sys.modules[mod_name]
    spec = importlib.util.spec_from_file_location(mod_name, path)
    if spec is None or spec.loader is None:
        raise ControllerLoadError(f"controller.type {kind!r}: cannot import {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = module
    try:
        spec.loader.exec_module(module)
    except KeyboardInterrupt:
        del sys.modules[mod_name]
        raise
    except BaseException as exc:  # sys.exit() at import too: bad input, one line
        del sys.modules[mod_name]
        raise ControllerLoadError(
            f"controller.type {kind!r}: importing {path} failed ({type(exc).__name__}: {exc})"
        ) from exc
    return module


def _import(kind: str, module_name: str):
    try:
        return importlib.import_module(module_name)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # sys.exit() at import too: bad input, one line
        raise ControllerLoadError(
            f"controller.type {kind!r}: cannot import module {module_name!r} "
            f"({type(exc).__name__}: {exc})"
        ) from exc
