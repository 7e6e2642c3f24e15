"""Run every benchmark module found in this package."""

import importlib
import pkgutil

import benchmarks


def main() -> None:
    for info in sorted(pkgutil.iter_modules(benchmarks.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"benchmarks.{info.name}")
        if hasattr(mod, "main"):
            print(f"== benchmarks.{info.name}")
            mod.main()


if __name__ == "__main__":
    main()
