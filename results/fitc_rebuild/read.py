#!/usr/bin/env python3
"""Paired readings of results/fitc_rebuild (the FITC-like rebuild, "switch", against the
default, same seeds), with results/dtc_absorb's readers:
``python results/fitc_rebuild/read.py results/fitc_rebuild > results/fitc_rebuild/read.md``."""

from __future__ import annotations

import sys
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

if __name__ == "__main__":
    root = Path(sys.argv[1])
    reader = load_script(Path(__file__).parents[1] / "dtc_absorb" / "read.py", "dtc_absorb_read")
    reader.critic_fit(root, range(20))
    reader.fixed_policy(root)
