"""The seed of each run, derived from what the run is, never from when it runs.

The seed of run ``seed_index`` of a case is the first 63 bits of a
:class:`numpy.random.SeedSequence` whose entropy is the root seed and the SHA-256 of the
case's canonical text (JSON, keys sorted, so the order of the parameters does not
matter), with ``seed_index`` as its spawn key.  It depends on the root seed, the
parameter values and the index only: adding a case, a seed or a worker, or running on
another executor, changes no other run's seed.  An explicit list of seeds is used as
given (the same seeds for every case, run ``i`` gets ``seeds[i]``).
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

import numpy as np

from .. import validate
from ..errors import ConfigurationError

__all__ = ["canonical", "run_seed", "seed_list"]


def canonical(params: dict[str, Any]) -> str:
    """The canonical text of a case *params* (parameter name -> JSON-serialisable value, no
    NaN): JSON with sorted keys and no spaces."""
    return json.dumps(params, sort_keys=True, separators=(",", ":"), allow_nan=False)


def run_seed(root_seed: int, params: dict[str, Any], seed_index: int) -> int:
    """The seed (an integer in ``[0, 2**63)``) of run *seed_index* of the case *params*, derived
    from the sweep's *root_seed* and the case's :func:`canonical` text (SHA-256)."""
    digest = hashlib.sha256(canonical(params).encode()).digest()
    entropy = [int(root_seed)] + [int.from_bytes(digest[i:i + 4], "little") for i in range(0, 32, 4)]
    state = np.random.SeedSequence(entropy, spawn_key=(int(seed_index),)).generate_state(2, np.uint32)
    return int(state[0]) | (int(state[1]) & 0x7FFFFFFF) << 32


def seed_list(seeds: Any) -> tuple[int, list[int] | None]:
    """``(count, explicit)``: the number of runs per case and, for an explicit list of
    seeds, the list (``None`` for a count).  Raises naming the value: a count that is not
    an integer >= 1, an empty list, a seed that is not an integer >= 0, a seed given twice."""
    if isinstance(seeds, (list, tuple)) or (isinstance(seeds, np.ndarray) and seeds.ndim == 1):
        from .grid import MAX_RUNS
        if len(seeds) > MAX_RUNS:
            raise ConfigurationError(f"seeds lists {len(seeds)} seeds, more than a sweep may run "
                                     f"(MAX_RUNS = {MAX_RUNS} runs)")
        given = list(seeds)
        if not given:
            raise ConfigurationError(f"seeds must list at least one seed, got {seeds!r}")
        out = [validate.integer(s, f"seeds[{i}]", lo=0, kind="a non-negative integer seed")
               for i, s in enumerate(given)]
        seen: set[int] = set()
        for s in out:                           # one pass (out.count(s) per seed was quadratic)
            if s in seen:
                text = repr(given) if len(given) <= 20 else f"{len(given)} seeds"
                raise ConfigurationError(f"seeds lists seed {s!r} twice: {text}")
            seen.add(s)
        return len(out), out
    return validate.integer(seeds, "seeds", lo=1,
                            kind="a number of seeds (an integer >= 1) or a list of seeds"), None
