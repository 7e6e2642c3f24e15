"""
The networked Fly-crane over lossy 802.11b (thesis §4.6.1, Fig. 4.11, appendix A)
=================================================================================

The experiment ``netcosim.experiments.flycrane_network`` in its quick mode (what
``python -m netcosim.experiments.flycrane_network --quick`` runs), written into a temporary
directory; each figure it writes is shown below.  ``--help`` describes it, and the full
run is ``python -m netcosim.experiments.flycrane_network``.
"""

# %%
import os
import tempfile
from pathlib import Path

import matplotlib.image as mpimg
import matplotlib.pyplot as plt

from netcosim.experiments import flycrane_network

quick = os.environ.get("NETCOSIM_DOCS_GALLERY", "quick") != "full"
out = Path(tempfile.mkdtemp(prefix="netcosim-gallery-"))
flycrane_network.main(outdir=str(out), quick=quick)

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

# %%
# The interactive timelines it wrote (the runs of Figs. A.4/A.5 at 20 % loss, online
# strategy): the planner on the platform, the robots' watchdogs and command tasks, the
# platform's broadcasts on 802.11b by outcome, the medium's busy periods and the error.
# ``docs/viewer.md`` describes the page.
pages = sorted(out.rglob("timeline_online_*.html"))
print([p.name for p in pages])
