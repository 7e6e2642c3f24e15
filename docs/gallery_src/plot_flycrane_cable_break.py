"""
A cable breaks during the Fly-crane's manoeuvre: which configurations still carry the load?
===========================================================================================

The experiment ``netcosim.experiments.flycrane_cable_break`` in its quick mode (what
``python -m netcosim.experiments.flycrane_cable_break --quick`` runs), written into a temporary
directory; each figure it writes is shown below.  ``--help`` describes it, and the full
run is ``python -m netcosim.experiments.flycrane_cable_break``.
"""

# %%
import os
import tempfile
from pathlib import Path

import matplotlib.image as mpimg
import matplotlib.pyplot as plt

from netcosim.experiments import flycrane_cable_break

quick = os.environ.get("NETCOSIM_DOCS_GALLERY", "quick") != "full"
out = Path(tempfile.mkdtemp(prefix="netcosim-gallery-"))
flycrane_cable_break.main(outdir=str(out), quick=quick)

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
