"""
Table 5.2 and Figs. 5.3, 5.4, 5.5, 5.7: SIKM stability set, optimal gain and period
===================================================================================

The experiment ``netcosim.experiments.ch5_table5_2`` in its quick mode (what
``python -m netcosim.experiments.ch5_table5_2 --quick`` runs), written into a temporary
directory; each figure it writes is shown below.  ``--help`` describes it, and the full
run is ``python -m netcosim.experiments.ch5_table5_2``.
"""

# %%
import os
import tempfile
from pathlib import Path

import matplotlib.image as mpimg
import matplotlib.pyplot as plt

from netcosim.experiments import ch5_table5_2

quick = os.environ.get("NETCOSIM_DOCS_GALLERY", "quick") != "full"
out = Path(tempfile.mkdtemp(prefix="netcosim-gallery-"))
ch5_table5_2.main(outdir=str(out), quick=quick)

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
