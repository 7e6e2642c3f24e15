"""
The DC servo and the tethered UAV as FMUs, through the loops of their Python versions
=====================================================================================

The experiment ``netcosim.experiments.fmu_servo`` in its quick mode (what
``python -m netcosim.experiments.fmu_servo --quick`` runs), written into a temporary
directory; each figure it writes is shown below.  ``--help`` describes it, and the full
run is ``python -m netcosim.experiments.fmu_servo``.
"""

# %%
import os
import tempfile
from pathlib import Path

import matplotlib.image as mpimg
import matplotlib.pyplot as plt

from netcosim.experiments import fmu_servo

quick = os.environ.get("NETCOSIM_DOCS_GALLERY", "quick") != "full"
out = Path(tempfile.mkdtemp(prefix="netcosim-gallery-"))
fmu_servo.main(outdir=str(out), quick=quick)

# %%
# The figures it wrote:
for png in sorted(out.rglob("*.png")):
    image = mpimg.imread(png)
    height, width = image.shape[:2]
    fig = plt.figure(figsize=(width / 100, height / 100), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.imshow(image)
    ax.set_axis_off()
    print(png.relative_to(out))
