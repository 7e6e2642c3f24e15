"""The test FMUs: compiled from C by :mod:`netcosim.fmi.demo` (its sources in netcosim/fmi/csrc/)."""

from netcosim.fmi.demo import build_fmu, build_se_fmu

__all__ = ["build_fmu", "build_se_fmu"]
