"""An FMU file opened for simulation: its ``modelDescription.xml``, its variables, its binary.

:class:`FMUFile` reads and checks an FMU (a zip with ``modelDescription.xml``) with FMPy,
extracts it to a temporary directory (removed when the object is collected), and
instantiates its model-exchange or co-simulation interface.  Every FMI call made through
:meth:`FMUFile.call` that returns an error status becomes an :class:`~netcosim.errors.FMUError`
naming the FMU, the FMI function and the simulated time.

FMPy is imported here, inside the functions, never when ``netcosim`` or ``netcosim.fmi`` is
imported (``pip install netcosim[fmi]`` installs it).
"""

from __future__ import annotations

import difflib
import math
import shutil
import tempfile
import weakref
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .. import validate
from ..errors import ConfigurationError, FMUError

__all__ = ["Variable", "FMUFile", "import_fmpy"]

#: the FMI variable types read and written as floats (s, and the variables' own units)
REAL_TYPES = ("Real", "Float64", "Float32")
INTEGER_TYPES = ("Integer", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64", "Enumeration")


def import_fmpy():
    """The ``fmpy`` module, or a clear error saying how to install it."""
    try:
        import fmpy
    except ImportError:  # pragma: no cover - the test environment has it
        raise ImportError("FMUs need FMPy: pip install 'netcosim[fmi]' (or pip install fmpy)") from None
    return fmpy


@dataclass(frozen=True)
class Variable:
    """One variable of an FMU's ``modelDescription.xml``: the signal metadata a plant exposes.

    ``unit`` is the unit string of the description (None when it gives none); ``start`` the
    start value as a float (None when it has none, e.g. a calculated variable).  ``name``: the
    FMI name; ``value_reference``: the FMI value reference; ``type``: e.g. ``"Real"``,
    ``"Float64"``, ``"Integer"``, ``"Boolean"``; ``causality`` (``"input"``, ``"output"``,
    ``"parameter"``, ``"local"``, ...) and ``variability`` (``"continuous"``, ``"tunable"``,
    ...) as in the description; ``description``: its text, or None.

    Examples
    --------
    The variables of the demo DC servo FMU (built from C with gcc by
    :func:`netcosim.fmi.demo.build_fmu`), as its plant model exposes them:

    >>> import shutil, tempfile
    >>> import pytest
    >>> if shutil.which("gcc") is None:      # the demo FMUs are compiled on this machine
    ...     pytest.skip("building the demo FMU needs gcc")
    >>> from netcosim.fmi import ModelExchangeFMU
    >>> from netcosim.fmi.demo import build_fmu
    >>> tmp = tempfile.TemporaryDirectory()
    >>> servo = ModelExchangeFMU(build_fmu("servo", 2, tmp.name))
    >>> u = servo.signals["u"]
    >>> u.name, u.value_reference, u.type, u.causality, u.variability, u.unit, u.start
    ('u', 4, 'Real', 'input', 'continuous', 'V', 0.0)
    >>> k = servo.file.variables["k"]
    >>> k.causality, k.unit, k.start
    ('parameter', 'rad/(V.s2)', 1000.0)
    >>> tmp.cleanup()
    """

    name: str
    value_reference: int
    type: str
    causality: str
    variability: str
    unit: str | None
    start: float | None
    description: str | None


def _start(v) -> float | None:
    if v.start is None:
        return None
    if isinstance(v.start, str) and v.start.lower() in ("true", "false"):
        return 1.0 if v.start.lower() == "true" else 0.0
    try:
        return float(v.start)
    except (TypeError, ValueError):
        return None


class FMUFile:
    """An FMU read from *path* (``.fmu``), its description checked, extracted for loading.

    ``fmi_version`` is 2 or 3; ``variables`` maps every variable name to its
    :class:`Variable`; ``model_description`` is FMPy's own object.  ``kind``: the interface
    used, ``"model exchange"``, ``"co-simulation"`` or ``"scheduled execution"`` (the FMU
    must provide it).

    Raises
    ------
    FMUError
        (:class:`~netcosim.errors.FMUError`) *path* does not exist, is not a zip
        archive, has no ``modelDescription.xml`` or one that is not XML, declares an FMI
        version other than 2.0 and 3.0, has a description FMPy rejects or cannot read,
        offers no *kind* interface, or cannot be extracted.
    ImportError
        FMPy is not installed (``pip install 'netcosim[fmi]'``).

    Examples
    --------
    The demo DC servo FMU, compiled with gcc by :func:`netcosim.fmi.demo.build_fmu`:

    >>> import shutil, tempfile
    >>> import pytest
    >>> if shutil.which("gcc") is None:      # the demo FMUs are compiled on this machine
    ...     pytest.skip("building the demo FMU needs gcc")
    >>> from netcosim.fmi import FMUFile
    >>> from netcosim.fmi.demo import build_fmu
    >>> tmp = tempfile.TemporaryDirectory()
    >>> fmu = FMUFile(build_fmu("servo", 2, tmp.name), kind="model exchange")
    >>> fmu.fmi_version, fmu.model_name, fmu.names("input"), fmu.names("output")
    (2, 'servo2', ('u',), ('y',))
    >>> fmu.names("parameter")
    ('k', 'a', 'fail_at', 'max_step')
    >>> fmu.variables["velocity"].unit
    'rad/s'
    >>> FMUFile("missing.fmu", kind="model exchange")
    Traceback (most recent call last):
      ...
    netcosim.errors.FMUError: FMU 'missing.fmu': no such file
    >>> tmp.cleanup()
    """

    def __init__(self, path: Any, *, kind: str):
        fmpy = import_fmpy()
        from fmpy.model_description import ValidationError
        self.path = Path(path)
        self.label = f"FMU {str(self.path)!r}"
        if not self.path.exists():
            raise FMUError(f"{self.label}: no such file")
        if not zipfile.is_zipfile(self.path):
            raise FMUError(f"{self.label}: not an FMU (not a zip archive)")
        version = _declared_version(self.path, self.label)
        if version.split(".")[0] not in ("2", "3"):
            raise FMUError(f"{self.label}: FMI version {version!r} is not supported (FMI 2.0 and 3.0 are)")
        try:
            md = fmpy.read_model_description(str(self.path))
        except ValidationError as exc:
            raise FMUError(f"{self.label}: invalid modelDescription.xml: {exc}") from None
        except Exception as exc:
            raise FMUError(f"{self.label}: cannot read modelDescription.xml: {exc}") from None
        self.model_description = md
        self.fmi_version = int(version.split(".")[0])
        self.kind = kind
        interface = {"model exchange": md.modelExchange, "co-simulation": md.coSimulation}.get(kind)
        if kind == "scheduled execution":
            interface = md.scheduledExecution
        if interface is None:
            offered = [k for k, i in (("model exchange", md.modelExchange), ("co-simulation", md.coSimulation),
                                      ("scheduled execution", getattr(md, "scheduledExecution", None))) if i]
            raise FMUError(f"{self.label}: has no {kind} interface (it offers {', '.join(offered) or 'none'})")
        self.interface = interface
        self.model_name = md.modelName
        self.variables: dict[str, Variable] = {
            v.name: Variable(v.name, int(v.valueReference), str(v.type), str(v.causality), str(v.variability),
                             v.unit or (v.declaredType.unit if v.declaredType is not None
                                        and getattr(v.declaredType, "unit", None) else None),
                             _start(v), v.description)
            for v in md.modelVariables}
        self._vr_names = {v.value_reference: n for n, v in self.variables.items()}
        self.directory = tempfile.mkdtemp(prefix="netcosim-fmu-")
        try:
            fmpy.extract(str(self.path), unzipdir=self.directory)
        except Exception as exc:
            shutil.rmtree(self.directory, ignore_errors=True)
            raise FMUError(f"{self.label}: cannot extract: {exc}") from None
        self.instance: Any = None
        self._finalizer = weakref.finalize(self, _release, [None], self.directory)

    # Variables -----------------------------------------------------------------
    def variable(self, name: str, role: str) -> Variable:
        """The variable *name*, or an error naming the FMU, the name (as a *role*, e.g.
        ``"parameter"``) and the closest names."""
        if not isinstance(name, str):
            raise ConfigurationError(f"{self.label}: {role} must be an FMI variable name (a string), got {name!r}")
        v = self.variables.get(name)
        if v is None:
            close = difflib.get_close_matches(name, list(self.variables), n=3)
            hint = f"; did you mean {', '.join(map(repr, close))}?" if close else ""
            raise ConfigurationError(f"{self.label}: unknown {role} variable {name!r}{hint} "
                                     f"(variables: {sorted(self.variables)})")
        return v

    def names(self, causality: str) -> tuple[str, ...]:
        """The names of the variables of this causality, in the description's order."""
        return tuple(n for n, v in self.variables.items() if v.causality == causality)

    def real(self, names: Sequence[str], role: str) -> list[int]:
        """The value references of *names*, each checked to be a real (Float64/Real) variable;
        *role* (e.g. ``"input"``) names their use in errors."""
        out = []
        for n in names:
            v = self.variable(n, role)
            if v.type not in REAL_TYPES:
                raise ConfigurationError(f"{self.label}: {role} variable {n!r} is of type {v.type}, "
                                         f"only real (Real/Float64) variables can be {role}s")
            out.append(v.value_reference)
        return out

    def name_of(self, vr: int) -> str:
        """The name of the variable with value reference *vr* (for messages)."""
        return self._vr_names.get(vr, f"value reference {vr}")

    # Instances -----------------------------------------------------------------
    def instantiate(self, instance_name: str, cls_name: str, **options):
        """Load the binary and instantiate it as FMPy class *cls_name* (``FMU2Model``, ...;
        *options* go to its ``instantiate``) under *instance_name* (the FMU's log and error
        messages name it)."""
        import fmpy.fmi2
        import fmpy.fmi3
        module = fmpy.fmi2 if self.fmi_version == 2 else fmpy.fmi3
        md = self.model_description
        try:
            fmu = getattr(module, cls_name)(guid=md.guid, unzipDirectory=self.directory,
                                            modelIdentifier=self.interface.modelIdentifier,
                                            instanceName=instance_name)
        except Exception as exc:
            raise FMUError(f"{self.label}: cannot load its binary for this platform: {exc}") from None
        try:
            fmu.instantiate(**options)
        except Exception as exc:
            raise FMUError(f"{self.label}: instantiation failed ({self.kind}, FMI {md.fmiVersion}): {exc}") from None
        self.instance = fmu
        self._finalizer.detach()
        self._finalizer = weakref.finalize(self, _release, [fmu], self.directory)
        return fmu

    def call(self, what: str, fn: Callable, *args, t: float | None = None, names: Sequence[str] = ()):
        """``fn(*args)``; an error status becomes an FMUError naming the FMU, *what* (the
        FMI function), the variables *names* and the time *t* (s)."""
        try:
            return fn(*args)
        except FMUError:
            raise
        except Exception as exc:
            where = f" at t={t!r} s" if t is not None else ""
            on = f" on {', '.join(map(repr, names))}" if names else ""
            raise FMUError(f"{self.label}: {what}{on} failed{where}: {exc}") from None

    def set_values(self, values: dict, role: str = "parameter") -> None:
        """Set variables by name (before initialisation): reals, integers and booleans, from
        *values* (``{FMI name: value}``); *role* (default ``"parameter"``) names them in errors.
        A real takes a finite number, an integer a whole number (``3`` or ``3.0``, not
        ``True`` or ``"3"``), a Boolean ``True``/``False`` or 1/0; anything else raises a
        :class:`~netcosim.errors.ConfigurationError` naming the variable and the value."""
        fmu = self.instance
        for name, value in values.items():
            v = self.variable(name, role)
            if v.causality not in ("parameter", "input") and v.variability != "tunable":
                if v.causality != "local" or v.start is None:
                    raise ConfigurationError(f"{self.label}: {role} {name!r} has causality {v.causality!r}, "
                                             f"only parameters, inputs and variables with a start value can be set")
            if v.type in REAL_TYPES:
                try:
                    x = float(value)
                except (TypeError, ValueError):
                    raise ConfigurationError(f"{self.label}: {role} {name!r} takes a number, got {value!r}") from None
                if not math.isfinite(x):
                    raise ConfigurationError(f"{self.label}: {role} {name!r} must be finite, got {value!r}")
                setter = ("setReal" if self.fmi_version == 2 else
                          "setFloat32" if v.type == "Float32" else "setFloat64")
            elif v.type in INTEGER_TYPES:
                if not (validate.is_real(value) and math.isfinite(value) and value == int(value)):
                    raise ConfigurationError(f"{self.label}: {role} {name!r} is of type {v.type} and takes a whole "
                                             f"number, got {value!r}")
                x = int(value)
                setter = "setInteger" if self.fmi_version == 2 else (
                    "setInt32" if v.type == "Enumeration" else f"set{v.type}")
            elif v.type == "Boolean":
                if not (isinstance(value, (bool, np.bool_)) or (validate.is_real(value) and value in (0, 1))):
                    raise ConfigurationError(f"{self.label}: {role} {name!r} is a Boolean and takes True or False "
                                             f"(or 1, 0), got {value!r}")
                x = bool(value)
                setter = "setBoolean"
            else:
                raise ConfigurationError(f"{self.label}: {role} {name!r} is of type {v.type}, which cannot be set")
            self.call(f"{setter}", getattr(fmu, setter), [v.value_reference], [x], names=[name])

    def signal_info(self, names: Sequence[str]) -> dict[str, Variable]:
        """The metadata of *names* (name -> :class:`Variable`)."""
        return {n: self.variables[n] for n in names if n in self.variables}


def _declared_version(path: Path, label: str) -> str:
    """The ``fmiVersion`` attribute of the FMU's ``modelDescription.xml`` (read before FMPy
    validates the description against that version's schema)."""
    import xml.etree.ElementTree as ET
    try:
        with zipfile.ZipFile(path) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
    except KeyError:
        raise FMUError(f"{label}: not an FMU (no modelDescription.xml in the archive)") from None
    except ET.ParseError as exc:
        raise FMUError(f"{label}: modelDescription.xml is not XML: {exc}") from None
    return str(root.get("fmiVersion", "?"))


def _release(holder: list, directory: str) -> None:
    """Free an FMU instance and remove its extracted files (at collection or exit)."""
    fmu = holder[0]
    if fmu is not None:
        try:
            fmu.freeInstance()
        except Exception:  # pragma: no cover - a failed FMU may refuse to be freed
            pass
        try:
            fmu.freeLibrary()
        except Exception:  # pragma: no cover
            pass
    shutil.rmtree(directory, ignore_errors=True)
