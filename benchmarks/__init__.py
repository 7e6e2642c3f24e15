"""Performance measurements. Each module has ``main()``; ``python -m benchmarks`` runs them all.

Timings are reported as ratios against a baseline measured in the same run, because
absolute wall-clock numbers on shared machines are noisy.
"""
