#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Every JSON document adit writes, checked against its schema in docs/schemas/.

Runs each verb once on the bundled test maps (small, fast runs), then for every document:
- `schema` and `schema_version` are its first two keys and name the schema it is checked against;
- it validates against that JSON Schema (draft 2020-12) with python3's jsonschema module;
- its numbers carry no float noise: at most 6 decimals (times to the microsecond, lengths to the
  millimetre; docs/formats.md "Numbers"), the exact `origin` of a shifted map excepted;
and the schemas are shown to bite: each document with a required field removed, or with a field
of the wrong type, must fail validation. CSV outputs are checked for the same precision.

Usage: output_schemas.py --adit BIN --repo SOURCE_DIR --workdir DIR
"""
import argparse
import copy
import csv
import json
import os
import shutil
import subprocess
import sys

try:
    import jsonschema
except ImportError:
    sys.exit("output_schemas.py: needs python3's jsonschema module: apt-get install python3-jsonschema "
             "(tools/quickstart.sh installs it with the test packages)")

failures = []


def fail(what):
    failures.append(what)
    print("FAIL: " + what)


def run(adit, args, ok_codes=(0,), cwd=None):
    p = subprocess.run([adit] + args, capture_output=True, text=True, cwd=cwd)
    if p.returncode not in ok_codes:
        fail("adit %s: exit %d (expected %s)\n%s" % (" ".join(args), p.returncode, ok_codes, p.stderr[-2000:]))
        return None
    return p.stdout


def decimals(x):
    text = repr(x)
    if "e" in text or "E" in text:
        return 99 if abs(x) < 1e-6 and x != 0 else 0
    return len(text.split(".")[1]) if "." in text else 0


def noisy_numbers(doc, path="", exempt=("origin",)):
    """Paths of floats with more than 6 decimals."""
    out = []
    if isinstance(doc, dict):
        for k, v in doc.items():
            if k not in exempt:
                out += noisy_numbers(v, path + "/" + k, exempt)
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += noisy_numbers(v, "%s/%d" % (path, i), exempt)
    elif isinstance(doc, float) and decimals(doc) > 6:
        out.append("%s = %r" % (path, doc))
    return out


def first_required(schema):
    return [k for k in schema.get("required", []) if k not in ("schema", "schema_version")]


def check(name, text, schemas, validators):
    """Parse `text` (one document), check it against the schema it names."""
    try:
        doc = json.loads(text)
    except (TypeError, ValueError) as e:
        fail("%s: not JSON: %s" % (name, e))
        return None
    if not isinstance(doc, dict):
        fail("%s: not a JSON object" % name)
        return None
    keys = list(doc.keys())
    if keys[:2] != ["schema", "schema_version"]:
        fail("%s: first keys are %s, expected schema, schema_version" % (name, keys[:2]))
        return None
    kind = doc["schema"]
    if kind not in validators:
        fail("%s: schema %r has no file in docs/schemas/" % (name, kind))
        return None
    errors = sorted(validators[kind].iter_errors(doc), key=lambda e: list(e.path))
    for e in errors[:5]:
        fail("%s (%s): /%s: %s" % (name, kind, "/".join(map(str, e.path)), e.message))
    for n in noisy_numbers(doc)[:5]:
        fail("%s: float noise at %s" % (name, n))
    # The schema must bite: a required field removed, and one mistyped, must each be refused.
    required = first_required(schemas[kind])
    if required:
        broken = copy.deepcopy(doc)
        del broken[required[0]]
        if validators[kind].is_valid(broken):
            fail("%s: still valid without its required field %r" % (name, required[0]))
        mistyped = copy.deepcopy(doc)
        mistyped[required[0]] = {"not": "the right type"}
        if validators[kind].is_valid(mistyped):
            fail("%s: still valid with %r mistyped" % (name, required[0]))
    wrong_version = copy.deepcopy(doc)
    wrong_version["schema_version"] = "1"
    if validators[kind].is_valid(wrong_version):
        fail("%s: still valid with schema_version a string" % name)
    print("ok   %-28s %s" % (kind, name))
    return doc


def check_csv(name, path, columns):
    """The named numeric columns of a CSV: at most `digits` decimals each."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        fail("%s: no rows" % name)
    for i, row in enumerate(rows):
        for col, digits in columns.items():
            v = row.get(col)
            if v is None:
                fail("%s: no column %s" % (name, col))
                return
            if v and "." in v and len(v.split(".")[1]) > digits:
                fail("%s:%d: %s = %s has more than %d decimals" % (name, i + 2, col, v, digits))
    print("ok   %-28s %s" % ("csv", name))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--adit", required=True)
    ap.add_argument("--repo", required=True)
    ap.add_argument("--workdir", required=True)
    a = ap.parse_args()
    schema_dir = os.path.join(a.repo, "docs", "schemas")
    schemas, validators = {}, {}
    for f in sorted(os.listdir(schema_dir)):
        if not f.endswith(".schema.json"):
            continue
        s = json.load(open(os.path.join(schema_dir, f)))
        jsonschema.Draft202012Validator.check_schema(s)
        kind = s["properties"]["schema"]["const"]
        schemas[kind] = s
        validators[kind] = jsonschema.Draft202012Validator(s)
    data = os.path.join(a.repo, "tests", "tools", "data")
    maps = os.path.join(a.repo, "maps")
    w = a.workdir
    shutil.rmtree(w, ignore_errors=True)
    os.makedirs(w)
    seen = set()

    def doc(name, text):
        d = check(name, text, schemas, validators) if text is not None else None
        if d:
            seen.add(d["schema"])
        return d

    def doc_file(name, path):
        if not os.path.exists(path):
            fail("%s: not written" % path)
            return None
        return doc(name, open(path).read())

    small = os.path.join(data, "small.yaml")
    plan_args = ["plan", "-q", "--map", small, "--start", "1.5,0,1.5", "--goal", "6,5,1.5", "--planner", "rrtconnect"]
    doc("plan --refine (stdout)", run(a.adit, plan_args + ["--refine"]))
    run(a.adit, plan_args + ["--out", os.path.join(w, "plan.json")])
    doc_file("plan --out plan.json", os.path.join(w, "plan.json"))
    if run(a.adit, plan_args + ["--out", os.path.join(w, "plan.csv")]) is not None:
        check_csv("plan --out plan.csv", os.path.join(w, "plan.csv"), {"x": 3, "y": 3, "z": 3})

    scen = os.path.join(maps, "scenarios")
    d = doc("simulate tian2016_straight", run(a.adit, ["simulate", "-q", os.path.join(scen, "tian2016_straight.yaml")]))
    if d:
        # Simulated time is step x dt: 0.1-second steps read as such, not 52.900000000000006.
        bad = [s["t"] for s in d["trajectory"] if decimals(s["t"]) > 3]
        if bad:
            fail("simulate: trajectory times off the step grid: %s" % bad[:3])
    doc("simulate sealed_roadway (navigated)",
        run(a.adit, ["simulate", "-q", os.path.join(scen, "sealed_roadway.yaml")], ok_codes=(1,)))
    doc("simulate subgoals", run(a.adit, ["simulate", "-q", os.path.join(scen, "tian2016_polyline_subgoals.yaml")],
                                 ok_codes=(0, 1)))

    loop = os.path.join(data, "campaign_loop.yaml")
    batch_csv = os.path.join(w, "batch.csv")
    run(a.adit, ["simulate", "-q", "--batch", "2", "--map", loop, "--out", os.path.join(w, "batch.json"),
                 "--csv", batch_csv], ok_codes=(0, 1))
    doc_file("simulate --batch 2", os.path.join(w, "batch.json"))
    if os.path.exists(batch_csv):
        check_csv("simulate --batch --csv", batch_csv,
                  {"arrival_time": 3, "path_length": 3, "min_clearance": 3, "final_goal_distance": 3})

    camp = os.path.join(w, "campaign")
    run(a.adit, ["campaign", "run", "-q", "--map", loop, "--scenarios", "2", "--seed", "11", "--out", camp],
        ok_codes=(0, 1))
    doc_file("campaign shard", os.path.join(camp, "shard-0-of-1.json"))
    run(a.adit, ["campaign", "merge", "-q", camp, "--out", os.path.join(w, "report.json")], ok_codes=(0, 1))
    doc_file("campaign merge report", os.path.join(w, "report.json"))

    doc("map info survey", run(a.adit, ["map", "info", "-q", "--json", small]))
    bt = os.path.join(w, "small.bt")
    run(a.adit, ["map", "convert", "-q", small, bt])
    doc("map info octomap", run(a.adit, ["map", "info", "-q", "--json", bt]))
    doc("map info scan", run(a.adit, ["map", "info", "-q", "--json", os.path.join(data, "tube_viewpoint.pcd")]))
    doc("map convert scan", run(a.adit, ["map", "convert", "-q", "--json", os.path.join(data, "tube.xyz"),
                                         os.path.join(w, "tube.bt"), "--seed", "3,0,1.2", "--resolution", "0.25"]))
    utm = os.path.join(w, "tube_utm.bt")
    doc("map convert UTM scan", run(a.adit, ["map", "convert", "-q", "--json", os.path.join(data, "tube_utm.csv"), utm,
                                             "--seed", "500003,4000000,801.2"]))
    doc_file("origin sidecar", utm + ".origin.json")
    doc("map convert ROS map", run(a.adit, ["map", "convert", "-q", "--json", os.path.join(data, "room.yaml"),
                                            os.path.join(w, "room.bt"), "--height", "2"]))
    doc("map graph survey --json", run(a.adit, ["map", "graph", "-q", small, "--json"]))
    run(a.adit, ["map", "graph", "-q", bt, "-o", os.path.join(w, "graph.json")])
    doc_file("map graph free space -o graph.json", os.path.join(w, "graph.json"))

    unused = sorted(set(schemas) - seen)
    if unused:
        fail("schemas no output was checked against: %s" % unused)
    if failures:
        print("%d failure(s)" % len(failures))
        return 1
    print("all %d schemas checked against adit's output" % len(schemas))
    return 0


if __name__ == "__main__":
    sys.exit(main())
