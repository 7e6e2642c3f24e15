"""Run every benchmark module found in this package (except tools that set ``RUN_WITH_ALL = False``)."""

import importlib
import pkgutil

import benchmarks


def main() -> None:
    for info in sorted(pkgutil.iter_modules(benchmarks.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"benchmarks.{info.name}")
        if hasattr(mod, "main") and getattr(mod, "RUN_WITH_ALL", True):
            print(f"== benchmarks.{info.name}")
            mod.main()


if __name__ == "__main__":
    main()
