"""
Thesis ch. 2, §2.6.2: landing of the tethered UAV on a 30° slope
================================================================

The experiment ``netcosim.experiments.ch2_landing`` in its quick mode (what
``python -m netcosim.experiments.ch2_landing --quick`` runs), written into a temporary
directory; each figure it writes is shown below.  ``--help`` describes it, and the full
run is ``python -m netcosim.experiments.ch2_landing``.
"""

# %%
import os
import tempfile
from pathlib import Path

import matplotlib.image as mpimg
import matplotlib.pyplot as plt

from netcosim.experiments import ch2_landing

quick = os.environ.get("NETCOSIM_DOCS_GALLERY", "quick") != "full"
out = Path(tempfile.mkdtemp(prefix="netcosim-gallery-"))
ch2_landing.main(outdir=str(out), quick=quick)

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
