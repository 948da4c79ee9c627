#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""`adit map convert --seed auto` on a generated scan of two stacked levels.

Two closed roadways 12 m long, 4 m wide and 3 m high, one above the other with 5 m of rock
between them (z 0..3 and 8..11). The rock between the levels has scanned surface above and below
it and lies farther from any scanned surface (2.5 m) than a roadway's inside (at most 1.5 m): a
seed chosen by distance alone would flood the rock. The chosen seed must lie inside a roadway, be
reported on stderr and in --json, and flood a plausible volume (within the two roadways' 288 m3).
The same scan shifted to UTM-like coordinates reports the seed in the input's frame, and a seed
on the scanned floor is refused quoting the point as typed, not shifted.

Usage: seed_auto_levels.py --adit BIN --workdir DIR
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys


def tube(z0, shift, step=0.1):
    """Surface points of a closed box roadway x 0..12, y -2..2, z z0..z0+3."""
    pts = []
    nx, ny, nz = int(12 / step), int(4 / step), int(3 / step)
    for i in range(nx + 1):
        x = i * step
        for j in range(ny + 1):
            y = -2 + j * step
            pts += [(x, y, z0), (x, y, z0 + 3)]
        for k in range(nz + 1):
            z = z0 + k * step
            pts += [(x, -2, z), (x, 2, z)]
    for j in range(ny + 1):
        for k in range(nz + 1):
            pts += [(0, -2 + j * step, z0 + k * step), (12, -2 + j * step, z0 + k * step)]
    return ["%.3f,%.3f,%.3f" % (p[0] + shift[0], p[1] + shift[1], p[2] + shift[2]) for p in pts]


def convert(adit, scan, out, seed, extra=()):
    return subprocess.run([adit, "map", "convert", "-q", "--json", scan, out, "--seed", seed,
                           "--resolution", "0.25"] + list(extra), capture_output=True, text=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--adit", required=True)
    ap.add_argument("--workdir", required=True)
    a = ap.parse_args()
    shutil.rmtree(a.workdir, ignore_errors=True)
    os.makedirs(a.workdir)
    bad = []
    for name, shift in (("levels", (0, 0, 0)), ("levels_utm", (500000, 4000000, 800))):
        scan = os.path.join(a.workdir, name + ".xyz")
        with open(scan, "w") as f:
            f.write("\n".join(tube(0, shift) + tube(8, shift)) + "\n")
        p = convert(a.adit, scan, os.path.join(a.workdir, name + ".bt"), "auto")
        if p.returncode != 0:
            bad.append("%s: exit %d: %s" % (name, p.returncode, p.stderr.strip()))
            continue
        j = json.loads(p.stdout)
        seed = j.get("seed")
        m = re.search(r"seed auto: chose (\S+),(\S+),(\S+) \(input frame\)", p.stderr)
        if not seed or j.get("seed_source") != "auto" or not m:
            bad.append("%s: the chosen seed is not reported (json %r, stderr %r)" % (name, seed, p.stderr))
            continue
        x, y, z = (seed[i] - shift[i] for i in range(3))
        in_tube = 0 < x < 12 and -2 < y < 2 and (0 < z < 3 or 8 < z < 11)
        if not in_tube:
            bad.append("%s: seed %r is not inside a roadway (z %.2f; the rock between the levels is z 3..8)"
                       % (name, seed, z))
        if [round(float(v), 3) for v in m.groups()] != [round(v, 3) for v in seed]:
            bad.append("%s: stderr %r and json %r name different seeds" % (name, m.groups(), seed))
        volume = j["free_volume_m3"]
        if not 50 < volume <= 288:
            bad.append("%s: %.1f m3 free: not one or two roadways' inside" % (name, volume))
        print("%s: seed %s, %.1f m3 free" % (name, seed, volume))
    # A seed on the lower level's floor, typed in the shifted (UTM) frame: the error quotes it so.
    typed = "500006,4000000,800.05"
    p = convert(a.adit, os.path.join(a.workdir, "levels_utm.xyz"), os.path.join(a.workdir, "rock.bt"), typed)
    if p.returncode != 2 or ("seed " + typed) not in p.stderr:
        bad.append("a seed in rock: exit %d, expected 2 and the seed as typed (%s) in: %s"
                   % (p.returncode, typed, p.stderr.strip()))
    for b in bad:
        print("FAIL: " + b)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
