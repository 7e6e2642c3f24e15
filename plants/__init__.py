"""Plant models of the reference application, as CasADi expressions and netcosim plants.

* :mod:`plants.tethered_uav` — the tethered UAV of thesis ch. 2;
* :mod:`plants.flycrane` — the Fly-crane family of ch. 3–5 and appendix B.

Conventions, equations and parameter choices: ``docs/models.md``.
"""
