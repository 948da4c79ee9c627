#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Writes a synthetic coal-mine district as a survey YAML on stdout, for trying adit at mine scale.

    python3 tools/synthetic_district.py 2000 1000 > d2km.yaml      # 2 km east x 1 km north
    adit plan --map d2km.yaml --farthest-ends

Two mains 40 m apart along the south edge with cross-cuts every 100 m, and longwall panels whose
gate roads (every 250 m) run north to faces at the far edge; a few degrees of dip. The same
district as `syntheticDistrict()` in tests/support/synthetic_roadway.cpp (the benchmarks' 2 km x
1 km district, about 13 km of roadway), so figures measured on either file compare.
"""
import argparse


def district(width, depth, panel):
    def z(x, y):
        return -0.03 * x + 0.04 * y  # a few degrees of dip

    stations, roadways, mains, returns = {}, [], [], []
    x = 0.0
    while x <= width + 1e-9:
        m, r = "M%d" % int(x), "R%d" % int(x)
        stations[m], stations[r] = (x, 0.0, z(x, 0)), (x, 40.0, z(x, 40))
        mains.append(m)
        returns.append(r)
        roadways.append(("crosscut-%d" % int(x), "gate", [m, r]))
        x += 100.0
    roadways += [("main", "main", mains), ("return", "main", returns)]
    gate, previous_top, x = 0, None, 50.0
    while x < width:
        g = "G%d" % gate
        stations[g + "a"], stations[g + "b"] = (x, 40.0, z(x, 40)), (x, depth, z(x, depth))
        roadways.append(("gate-%d" % gate, "gate", [g + "a", g + "b"]))
        if gate % 2 == 1:
            roadways.append(("face-%d" % (gate // 2), "face", [previous_top, g + "b"]))
        previous_top = g + "b"
        x += panel
        gate += 1
    return stations, roadways


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("width", type=float, help="east extent [m], at least 100")
    ap.add_argument("depth", type=float, help="north extent [m], more than 40")
    ap.add_argument("--resolution", type=float, default=0.2, help="voxel edge [m] (default 0.2)")
    ap.add_argument("--panel", type=float, default=250.0, help="gate road spacing [m] (default 250)")
    a = ap.parse_args()
    if not (a.width >= 100 and a.depth > 40 and a.resolution > 0 and a.panel > 0):
        ap.error("need width >= 100, depth > 40, resolution > 0 and panel > 0")
    stations, roadways = district(a.width, a.depth, a.panel)
    out = ["# synthetic district %g x %g m (tools/synthetic_district.py)" % (a.width, a.depth),
           "name: synthetic-district", "resolution: %g" % a.resolution, "rock_shell: 0.6", "stations:"]
    out += ["  %s: [%g, %g, %.3f]" % (k, x, y, zz) for k, (x, y, zz) in stations.items()]
    out += ["sections:",
            "  main: {shape: arch, width: 4.8, wall_height: 1.5}",
            "  gate: {shape: rectangle, width: 4.5, height: 3.5}",
            "  face: {shape: rectangle, width: 4.2, height: 3.0}",
            "roadways:"]
    out += ["  - {name: %s, section: %s, stations: [%s]}" % (n, s, ", ".join(st)) for n, s, st in roadways]
    print("\n".join(out))


if __name__ == "__main__":
    main()
