"""Small FMUs built from C on this machine (gcc): the DC servo, a bouncing ball and a
Scheduled Execution FMU, for the tests, the example ``fmu_servo`` and the benchmark
``fmu_overhead`` (no FMU is downloaded).

``build_fmu(model, fmi, directory)`` compiles ``fmi{2,3}_model.c`` around the model's header
(``servo.h``: the DC servo 1000/(s(s+1)); ``ball.h``: a bouncing ball with a state event;
``ramp.h``: a ramp whose slope changes sign at a time event)
with the FMI headers FMPy ships (``fmpy/c-code``), writes ``modelDescription.xml`` (both
interfaces, model exchange and co-simulation, in one FMU) and zips them.  The FMI functions
a model does not implement are stubs returning an error (FMPy binds every function of the
standard when it loads a binary).
"""

from __future__ import annotations

import re
import subprocess
import zipfile
from pathlib import Path
from typing import Any

from ..errors import ConfigurationError

__all__ = ["build_fmu", "build_se_fmu", "MODELS"]

HERE = Path(__file__).resolve().parent / "csrc"

# name, value reference, causality, variability, start (None: calculated), unit, derivative of (vr)
SERVO = dict(guid="{netcosim-servo-1}", indicators=[], variables=[
    ("angle", 0, "local", "continuous", 0.0, "rad", None),
    ("velocity", 1, "local", "continuous", 0.0, "rad/s", None),
    ("der(angle)", 2, "local", "continuous", None, "rad/s", 0),
    ("der(velocity)", 3, "local", "continuous", None, "rad/s2", 1),
    ("u", 4, "input", "continuous", 0.0, "V", None),
    ("y", 5, "output", "continuous", None, "rad", None),
    ("k", 6, "parameter", "fixed", 1000.0, "rad/(V.s2)", None),
    ("a", 7, "parameter", "fixed", 1.0, "1/s", None),
    ("fail_at", 8, "parameter", "fixed", 1e300, "s", None),
    ("max_step", 9, "parameter", "fixed", 1e300, "s", None),
])
BALL = dict(guid="{netcosim-ball-1}", indicators=[0], variables=[
    ("h", 0, "output", "continuous", 1.0, "m", None),
    ("v", 1, "output", "continuous", 0.0, "m/s", None),
    ("der(h)", 2, "local", "continuous", None, "m/s", 0),
    ("der(v)", 3, "local", "continuous", None, "m/s2", 1),
    ("g", 4, "parameter", "fixed", 9.81, "m/s2", None),
    ("e", 5, "parameter", "fixed", 0.7, "1", None),
    ("fail_at", 6, "parameter", "fixed", 1e300, "s", None),
    ("max_step", 7, "parameter", "fixed", 1e300, "s", None),
])
RAMP = dict(guid="{netcosim-ramp-1}", indicators=[], variables=[
    ("x", 0, "local", "continuous", 0.0, "m", None),
    ("der(x)", 1, "local", "continuous", None, "m/s", 0),
    ("slope", 2, "local", "discrete", 1.0, "m/s", None),
    ("T", 3, "parameter", "fixed", 0.5, "s", None),
    ("fail_at", 4, "parameter", "fixed", 1e300, "s", None),
    ("max_step", 5, "parameter", "fixed", 1e300, "s", None),
    ("y", 6, "output", "continuous", None, "m", None),
])
#: the models build_fmu compiles: name -> GUID, event indicators (value references), variables
MODELS: dict[str, dict[str, Any]] = {"servo": SERVO, "ball": BALL, "ramp": RAMP}


def _fmi2_xml(name, spec, guid):
    units = sorted({v[5] for v in spec["variables"]})
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<fmiModelDescription fmiVersion="2.0" modelName="{name}" guid="{guid}" '
           f'numberOfEventIndicators="{len(spec["indicators"])}">',
           f'<ModelExchange modelIdentifier="{name}"/>',
           f'<CoSimulation modelIdentifier="{name}" canHandleVariableCommunicationStepSize="true" '
           'canGetAndSetFMUstate="true"/>',
           '<UnitDefinitions>', *(f'<Unit name="{u}"/>' for u in units), '</UnitDefinitions>',
           '<ModelVariables>']
    index = {}
    for i, (vname, vr, caus, var, start, unit, der) in enumerate(spec["variables"], start=1):
        index[vr] = i
        causality = "local" if caus == "local" else caus
        attrs = f'name="{vname}" valueReference="{vr}" causality="{causality}" variability="{var}"'
        if start is not None and caus != "input":
            attrs += ' initial="exact"'
        real = f'unit="{unit}"'
        if start is not None:
            real += f' start="{start!r}"'
        if der is not None:
            real += f' derivative="{index[der]}"'
        out.append(f'<ScalarVariable {attrs}><Real {real}/></ScalarVariable>')
    out.append('</ModelVariables><ModelStructure>')
    outputs = [index[v[1]] for v in spec["variables"] if v[2] == "output"]
    out.append('<Outputs>' + ''.join(f'<Unknown index="{i}"/>' for i in outputs) + '</Outputs>')
    ders = [index[v[1]] for v in spec["variables"] if v[6] is not None]
    out.append('<Derivatives>' + ''.join(f'<Unknown index="{i}"/>' for i in ders) + '</Derivatives>')
    out.append('</ModelStructure></fmiModelDescription>')
    return "\n".join(out)


def _fmi3_xml(name, spec, guid):
    units = sorted({v[5] for v in spec["variables"]})
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<fmiModelDescription fmiVersion="3.0" modelName="{name}" instantiationToken="{guid}">',
           f'<ModelExchange modelIdentifier="{name}"/>',
           f'<CoSimulation modelIdentifier="{name}" canHandleVariableCommunicationStepSize="true" '
           'canGetAndSetFMUState="true" canReturnEarlyAfterIntermediateUpdate="true"/>',
           '<UnitDefinitions>', *(f'<Unit name="{u}"/>' for u in units), '</UnitDefinitions>',
           '<ModelVariables>',
           '<Float64 name="time" valueReference="999" causality="independent" variability="continuous"/>']
    for vname, vr, caus, var, start, unit, der in spec["variables"]:
        attrs = f'name="{vname}" valueReference="{vr}" causality="{caus}" variability="{var}" unit="{unit}"'
        if start is not None and caus != "input":
            attrs += ' initial="exact"'
        if start is not None:
            attrs += f' start="{start!r}"'
        if der is not None:
            attrs += f' derivative="{der}"'
        out.append(f'<Float64 {attrs}/>')
    out.append('</ModelVariables><ModelStructure>')
    out += [f'<Output valueReference="{v[1]}"/>' for v in spec["variables"] if v[2] == "output"]
    out += [f'<ContinuousStateDerivative valueReference="{v[1]}"/>' for v in spec["variables"] if v[6] is not None]
    out += [f'<EventIndicator valueReference="{vr}"/>' for vr in spec["indicators"]]
    out.append('</ModelStructure></fmiModelDescription>')
    return "\n".join(out)


def _stubs(fmi: int, source: str) -> str:
    """C stubs (returning fmiError) for the functions FMPy binds that *source* does not define."""
    from fmpy import fmi2, fmi3
    classes = ([fmi2.FMU2Model, fmi2.FMU2Slave] if fmi == 2
               else [fmi3.FMU3Model, fmi3.FMU3Slave, fmi3.FMU3ScheduledExecution])
    wanted = {n for c in classes for n in dir(c) if n.startswith(f"fmi{fmi}")}
    defined = set(re.findall(rf"\b(fmi{fmi}\w+)\(", source))
    return "\n".join(f"int {n}(void) {{ return 3; }}" for n in sorted(wanted - defined)) + "\n"


def build_fmu(model: str, fmi: int, directory, *, guid: str | None = None, fmi_version: str | None = None,
              name: str | None = None) -> Path:
    """Compile *model* (``"servo"``, ``"ball"`` or ``"ramp"``) as an FMI *fmi* (2 or 3) FMU in *directory*.

    *guid*: the GUID/instantiation token written to the XML (a different one than the
    binary's makes instantiation fail); *fmi_version*: the fmiVersion attribute written
    (e.g. ``"1.0"`` for a wrong-version FMU); *name*: the FMU's file and build folder name
    (default ``<model><fmi>``, e.g. ``"servo2"``).  Returns the ``.fmu`` path."""
    import shutil

    import fmpy
    if model not in MODELS:
        raise ConfigurationError(f"demo FMU model must be one of {sorted(MODELS)}, got {model!r}")
    if fmi not in (2, 3):
        raise ConfigurationError(f"demo FMU FMI version must be 2 or 3, got {fmi!r}")
    if shutil.which("gcc") is None:
        raise ConfigurationError("building the demo FMUs needs gcc on the PATH")
    spec = MODELS[model]
    name = name or f"{model}{fmi}"
    work = Path(directory) / name
    binaries = work / "binaries" / ("linux64" if fmi == 2 else "x86_64-linux")
    binaries.mkdir(parents=True, exist_ok=True)
    src = HERE / f"fmi{fmi}_model.c"
    stubs = work / "stubs.c"
    stubs.write_text(_stubs(fmi, src.read_text()))
    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O2", f"-I{headers}", f"-I{HERE}", f'-DMODEL_H="{model}.h"',
                    "-o", str(binaries / f"{name}.so"), str(src), str(stubs), "-lm"],
                   check=True, capture_output=True, text=True)
    xml = (_fmi2_xml if fmi == 2 else _fmi3_xml)(name, spec, guid or spec["guid"])
    if fmi_version is not None:
        xml = re.sub(r'fmiVersion="[^"]*"', f'fmiVersion="{fmi_version}"', xml, count=1)
    path = Path(directory) / f"{name}.fmu"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", xml)
        z.write(binaries / f"{name}.so", f"binaries/{binaries.name}/{name}.so")
    return path


SE_XML = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="se" instantiationToken="{netcosim-se-1}">
<ScheduledExecution modelIdentifier="se"/>
<UnitDefinitions><Unit name="s"/></UnitDefinitions>
<ModelVariables>
<Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
<Clock name="fast" valueReference="1" causality="input" intervalVariability="constant" intervalDecimal="0.005"/>
<Clock name="slow" valueReference="2" causality="input" intervalVariability="constant" intervalDecimal="0.008"/>
<Float64 name="fast_count" valueReference="3" causality="output" variability="discrete" clocks="1" initial="exact"
 start="0"/>
<Float64 name="fast_time" valueReference="4" causality="output" variability="discrete" clocks="1" initial="exact"
 start="0" unit="s"/>
<Float64 name="slow_count" valueReference="5" causality="output" variability="discrete" clocks="2" initial="exact"
 start="0"/>
<Float64 name="slow_time" valueReference="6" causality="output" variability="discrete" clocks="2" initial="exact"
 start="0" unit="s"/>
<Float64 name="gain" valueReference="7" causality="parameter" variability="fixed" start="2"/>
<Float64 name="fast_out" valueReference="8" causality="output" variability="discrete" clocks="1" initial="exact"
 start="0"/>
</ModelVariables>
<ModelStructure>
<Output valueReference="3"/><Output valueReference="4"/><Output valueReference="5"/><Output valueReference="6"/>
<Output valueReference="8"/>
</ModelStructure>
</fmiModelDescription>
"""


def build_se_fmu(directory) -> Path:
    """The FMI 3.0 Scheduled Execution FMU of ``fmus/fmi3_se.c``: clocks ``fast`` (5 ms) and
    ``slow`` (8 ms), each partition counting its activations, built with gcc in *directory*
    (a folder ``se`` for the build, the FMU as ``se.fmu``); returns the FMU's path."""
    import fmpy
    work = Path(directory) / "se"
    binaries = work / "binaries" / "x86_64-linux"
    binaries.mkdir(parents=True, exist_ok=True)
    src = HERE / "fmi3_se.c"
    stubs = work / "stubs.c"
    stubs.write_text(_stubs(3, src.read_text()))
    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O2", f"-I{headers}", "-o", str(binaries / "se.so"), str(src),
                    str(stubs)], check=True, capture_output=True, text=True)
    path = Path(directory) / "se.fmu"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", SE_XML)
        z.write(binaries / "se.so", "binaries/x86_64-linux/se.so")
    return path
