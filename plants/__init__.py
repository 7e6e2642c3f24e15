"""Plant models of the reference application, as CasADi expressions and netcosim plants.

* :mod:`netcosim.plants.tethered_uav` — the tethered UAV of thesis ch. 2;
* :mod:`netcosim.plants.flycrane` — the Fly-crane family of ch. 3–5 and appendix B.

Conventions, equations and parameter choices: ``docs/models.md``.
"""
