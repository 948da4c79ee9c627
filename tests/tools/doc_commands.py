#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Runs every command a user would copy from README.md and docs/*.md, so the docs cannot go stale.

    doc_commands.py --adit BIN [--repo DIR] [--workdir DIR] [--jobs N] [--timeout S]
                    [--slowdown K] [--keep] [--list] [FILE.md ...]

What is a command: in a fenced block marked ```sh or ```console, a line that starts with `adit `
(or `build/bin/adit `); in a console block only after the prompt `$ `, the other lines being
output. A line ending in a backslash continues on the next. `bash tools/quickstart.sh ...` lines
are left to CI (.ci/run runs the test command) and reported as skipped; any other line (cmake,
comments, output) is not a command.

Each command runs under bash, from a scratch directory of its own doc file, in which maps/, tests/
and tools/ are links to the repository's and `adit` and `build/bin/adit` are BIN; so the
commands' relative inputs are the repository's and their outputs land in the scratch directory.
The commands of one file run in order (a later one may read what an earlier one wrote); files run
in parallel (--jobs). A command must exit with the code its line states in a trailing comment
(`# exit 2`), else 0; one that does not, or takes longer than --timeout seconds (x --slowdown),
fails the test, named by file, line and command, with the end of its output.

A block that needs what this test cannot have is marked on the line before its fence:
    <!-- doc-test: skip (needs ../shared/data) -->
Its commands are listed as skipped, with the reason.

A newcomer's path: the README's commands run in order, as a user types them; after a command that
succeeds, every output it names (`--out`, `-o`, `--csv`, `--html`, `--picture`, `--svg`, `--json`
with a file) must exist and parse as its kind: JSON (and, when it names a schema, valid against
docs/schemas/, python3's jsonschema), CSV with a header and rows of its width, PNG by its
signature, SVG and HTML by their root element; a campaign's `--out DIR` must hold a shard JSON that
validates. Outputs to devices (/dev/null, /dev/stdout) and to stdout (`-`) are not files to check.

Exit 0 when every command did what its line says, 1 when one did not, 2 on bad usage (or when no
command was found at all: the extraction would then be what is broken).
"""
import argparse
import concurrent.futures
import csv
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

FENCE = re.compile(r"^\s*```\s*([A-Za-z0-9_+-]*)")
SKIP = re.compile(r"<!--\s*doc-test:\s*skip\s*\((.*)\)\s*-->")
EXPECT = re.compile(r"\s#\s*exit\s+(\d+)\b")
COMMAND_PREFIXES = ("adit ", "build/bin/adit ")
CI_PREFIX = "bash tools/"
RUN_LANGS = ("sh", "console")
REPO_LINKS = ("maps", "tests", "tools")


class Command:
    def __init__(self, doc, line, text, expect, skip):
        self.doc, self.line, self.text, self.expect, self.skip = doc, line, text, expect, skip

    def where(self):
        return f"{self.doc}:{self.line}"


def extract(path, rel):
    """The commands of one Markdown file, in order."""
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    out = []
    lang = None            # inside a fence: its language ('' when none)
    skip = None            # the reason of a doc-test: skip before the current fence
    last_text = ""         # the previous non-blank line outside a fence
    pending = None         # (first line number, text so far) of a command continued by '\'
    for no, raw in enumerate(lines, 1):
        if lang is None:
            m = FENCE.match(raw)
            if m:
                lang = m.group(1).lower()
                s = SKIP.search(last_text)
                skip = s.group(1).strip() if s else None
            elif raw.strip():
                last_text = raw
            continue
        if FENCE.match(raw) and raw.strip() == "```":
            lang = None
            last_text = ""
            continue
        if lang not in RUN_LANGS:
            continue
        if pending is not None:
            start, text = pending
            text += " " + raw.strip()
        else:
            line = raw.strip()
            if lang == "console":
                if not line.startswith("$ "):
                    continue
                line = line[2:].strip()
            elif line.startswith("$ "):
                line = line[2:].strip()
            start, text = no, line
        if text.endswith("\\"):
            pending = (start, text[:-1].rstrip())
            continue
        pending = None
        if text.startswith(CI_PREFIX):
            out.append(Command(rel, start, text, 0, "left to CI (.ci/run runs the quick start's test command)"))
        elif text.startswith(COMMAND_PREFIXES):
            m = EXPECT.search(text)
            out.append(Command(rel, start, text, int(m.group(1)) if m else 0, skip))
    if lang is not None:
        raise SystemExit(f"{rel}: a fenced block is not closed")
    return out


def prepare(scratch, repo, adit):
    os.makedirs(os.path.join(scratch, "build", "bin"))
    os.makedirs(os.path.join(scratch, "bin"))
    os.makedirs(os.path.join(scratch, "out"))
    for d in REPO_LINKS:
        os.symlink(os.path.join(repo, d), os.path.join(scratch, d))
    os.symlink(adit, os.path.join(scratch, "bin", "adit"))
    os.symlink(adit, os.path.join(scratch, "build", "bin", "adit"))


CHECKED = []  # every output checked (list.append is atomic under the GIL: the files' threads share it)
OUTPUT_FLAGS = ("--out", "-o", "--csv", "--html", "--picture", "--svg", "--json")


def load_validators(repo):
    """{schema name: validator} from docs/schemas/, or None without python3's jsonschema."""
    try:
        import jsonschema
    except ImportError:
        return None
    validators = {}
    schema_dir = os.path.join(repo, "docs", "schemas")
    for f in sorted(os.listdir(schema_dir)):
        if f.endswith(".schema.json"):
            with open(os.path.join(schema_dir, f)) as fh:
                s = json.load(fh)
            validators[s["properties"]["schema"]["const"]] = jsonschema.Draft202012Validator(s)
    return validators


def named_outputs(text):
    """The files a command line names as its outputs (the value after an output flag)."""
    try:
        words = shlex.split(text, comments=True)
    except ValueError:
        return []
    out = []
    for i, w in enumerate(words):
        flag, _, value = w.partition("=")
        if flag in OUTPUT_FLAGS:
            if not value and i + 1 < len(words) and not words[i + 1].startswith("-"):
                value = words[i + 1]
            if value and value != "-" and not value.startswith("/dev/"):
                out.append(value)
    return out


def check_json(path, validators):
    with open(path, encoding="utf-8") as fh:
        doc = json.load(fh)
    kind = doc.get("schema") if isinstance(doc, dict) else None
    if kind and validators is not None:
        if kind not in validators:
            return f"names schema {kind!r}, which docs/schemas/ does not have"
        errors = list(validators[kind].iter_errors(doc))
        if errors:
            e = errors[0]
            return f"not valid against {kind}: /{'/'.join(map(str, e.path))}: {e.message}"
    return None


def check_output(path, validators):
    """None when the file at `path` is there and parses as its kind, else why not."""
    if os.path.isdir(path):
        shards = [f for f in sorted(os.listdir(path)) if re.fullmatch(r"shard-\d+-of-\d+\.json", f)]
        if not shards:
            return "a directory without a shard JSON"
        return check_json(os.path.join(path, shards[0]), validators)
    if not os.path.isfile(path):
        return "was not written"
    if os.path.getsize(path) == 0:
        return "is empty"
    ext = os.path.splitext(path)[1].lower()
    try:
        if ext == ".json":
            return check_json(path, validators)
        if ext == ".csv":
            with open(path, newline="", encoding="utf-8") as fh:
                rows = list(csv.reader(fh))
            if len(rows) < 2:
                return "a CSV without rows"
            bad = [i + 1 for i, r in enumerate(rows) if len(r) != len(rows[0])]
            return f"CSV line {bad[0]} is not as wide as its header" if bad else None
        with open(path, "rb") as fh:
            head = fh.read(4096)
        if ext == ".png" and not head.startswith(b"\x89PNG\r\n\x1a\n"):
            return "not a PNG"
        if ext == ".svg" and b"<svg" not in head:
            return "not an SVG"
        if ext == ".html" and b"<html" not in head.lower():
            return "not an HTML page"
    except (ValueError, UnicodeDecodeError, csv.Error) as e:
        return f"does not parse: {e}"
    return None


def tail(text, n=12):
    rows = text.strip("\n").split("\n")
    return "\n".join("    | " + r for r in rows[-n:]) if text.strip() else "    | (no output)"


def run_file(rel, commands, args, root):
    """Runs one file's commands in its scratch directory; returns (results, log lines)."""
    scratch = os.path.join(root, re.sub(r"[^A-Za-z0-9_.-]", "_", rel))
    prepare(scratch, args.repo, args.adit)
    env = dict(os.environ)
    env["PATH"] = os.path.join(scratch, "bin") + os.pathsep + env.get("PATH", "")
    results = []
    for c in commands:
        if c.skip:
            continue
        t0 = time.monotonic()
        try:
            p = subprocess.run(["bash", "-c", c.text], cwd=scratch, env=env, stdin=subprocess.DEVNULL,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               timeout=args.timeout * args.slowdown)
            code, output = p.returncode, p.stdout.decode("utf-8", "replace")
        except subprocess.TimeoutExpired as e:
            code = None
            output = (e.stdout or b"").decode("utf-8", "replace")
        if code == 0 and c.expect == 0:
            for out in named_outputs(c.text):
                why = check_output(os.path.join(scratch, out), args.validators)
                CHECKED.append(out)
                if why:
                    code = -1
                    output += f"\noutput {out}: {why}"
        results.append((c, code, output, time.monotonic() - t0))
    return results


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--adit", required=True, help="the built adit binary")
    ap.add_argument("--repo", default=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                    help="the repository root (default: this script's)")
    ap.add_argument("--workdir", help="where the scratch directories go (default: a temporary directory)")
    ap.add_argument("--jobs", type=int, default=2, help="doc files run at once (default 2)")
    ap.add_argument("--timeout", type=float, default=120, help="seconds per command (default 120)")
    ap.add_argument("--slowdown", type=float, default=1, help="multiplies --timeout (sanitizer builds)")
    ap.add_argument("--keep", action="store_true", help="keep the scratch directories")
    ap.add_argument("--list", action="store_true", help="only list the commands and what is skipped")
    ap.add_argument("files", nargs="*", help="Markdown files (default: README.md and docs/*.md)")
    args = ap.parse_args()
    args.repo = os.path.abspath(args.repo)
    args.adit = os.path.abspath(args.adit)
    if not args.list and not os.access(args.adit, os.X_OK):
        print(f"doc_commands: {args.adit}: not an executable", file=sys.stderr)
        return 2
    files = args.files or (["README.md"] + sorted(
        os.path.join("docs", f) for f in os.listdir(os.path.join(args.repo, "docs")) if f.endswith(".md")))
    by_file = {}
    for f in files:
        path = f if os.path.isabs(f) else os.path.join(args.repo, f)
        rel = os.path.relpath(path, args.repo)
        by_file[rel] = extract(path, rel)
    everything = [c for cs in by_file.values() for c in cs]
    if not everything:
        print("doc_commands: no command found in " + ", ".join(by_file), file=sys.stderr)
        return 2
    skipped = [c for c in everything if c.skip]
    for c in skipped:
        print(f"skip {c.where()}: {c.text}\n     ({c.skip})")
    to_run = {f: cs for f, cs in by_file.items() if any(not c.skip for c in cs)}
    if args.list:
        for c in everything:
            if not c.skip:
                print(f"run  {c.where()}: {c.text}" + (f"   [exit {c.expect}]" if c.expect else ""))
        print(f"{len(everything) - len(skipped)} to run, {len(skipped)} skipped")
        return 0

    args.validators = load_validators(args.repo)
    if args.validators is None:
        print("doc_commands: no python3 jsonschema module: JSON outputs are parsed, not validated")
    root = os.path.abspath(args.workdir) if args.workdir else tempfile.mkdtemp(prefix="adit-doc-commands-")
    if args.workdir:
        shutil.rmtree(root, ignore_errors=True)
        os.makedirs(root)
    t0 = time.monotonic()
    failed = []
    ran = 0
    # The files with the most work first (a command on the district loads a 2603 m map; a campaign
    # or a replay runs whole missions), so that the short ones fill in beside them.
    def weight(item):
        return sum(1 + 3 * any(k in c.text for k in ("district", "campaign", "--replay"))
                   for c in item[1] if not c.skip)
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(run_file, f, cs, args, root): f
                   for f, cs in sorted(to_run.items(), key=weight, reverse=True)}
        for fut in concurrent.futures.as_completed(futures):
            for c, code, output, secs in fut.result():
                ran += 1
                if code == c.expect:
                    print(f"ok   {c.where()} ({secs:.1f} s, exit {code}): {c.text}")
                    continue
                why = (f"timed out after {args.timeout * args.slowdown:.0f} s" if code is None
                       else "an output it names is missing or does not parse" if code == -1
                       else f"exit {code}, the doc says {c.expect}")
                print(f"FAIL {c.where()} ({why}): {c.text}\n{tail(output)}")
                failed.append((c, why))
    print(f"doc_commands: {ran} commands run in {time.monotonic() - t0:.1f} s, {len(skipped)} skipped, "
          f"{len(failed)} failed; {len(CHECKED)} outputs they name checked "
          f"({sum(o.endswith('.json') or '.' not in os.path.basename(o) for o in CHECKED)} JSON or campaign directories)")
    for c, why in sorted(failed, key=lambda x: (x[0].doc, x[0].line)):
        print(f"  {c.where()}: {why}: {c.text}")
    if failed or args.keep:
        print(f"scratch directories kept in {root}")
    else:
        shutil.rmtree(root, ignore_errors=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
