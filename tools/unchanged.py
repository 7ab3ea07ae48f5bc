#!/usr/bin/env python3
"""Behaviour unchanged, shown: `seam compare --json` on every bundled scene, under several
settings, recorded once and checked against later, every figure but timings.

    tools/unchanged.py record DIR   # before a change: writes DIR/<scene>__<setting>.json
    tools/unchanged.py check DIR    # after it: the same runs, compared figure by figure
    tools/unchanged.py pair OLD NEW # both binaries, each run back to back (no DIR)

Timings (keys ending in `_us`) are left out. `events_bytes_per_tick` is compared to within
0.5 %: events frames carry host timestamps (published, issued) and op numbers started from
the wall clock, postcard varints whose length follows the clock. Every other figure must be
identical: lock-step trials are deterministic (rapier's enhanced-determinism, frames counted
per tick, ids from one fixed run name), so any other difference is a change of behaviour. The clock moves those lengths over an hour (a
`check` against a record made an hour earlier can differ by 3 % in that figure alone, the old
binary as much as the new); `pair` runs the binary before the change and the one after on
each run back to back, so both see the same clock. `SEAM_BIN` names the `seam` binary (default:
target/release/seam, built with `cargo build --release -p seam-bench --bin seam`).
"""
import glob
import json
import os
import subprocess
import sys

SETTINGS = {
    "default": [],
    "kinematic": ["--proxy-mode", "kinematic"],
    "interval4-quantized": ["--replication-interval", "4", "--quantize"],
    "scripted": ["--authority", "scripted"],
    "no-coupling": ["--no-coupling"],
    "everything": ["--everything"],
}


def scenes():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    found = sorted(glob.glob(os.path.join(root, "bench/scenes/*.toml")))
    found += sorted(glob.glob(os.path.join(root, "bench/scenes/variants/*.toml")))
    found += sorted(glob.glob(os.path.join(root, "bench/scenes/open/*.toml")))
    return found


def strip(value):
    """The document without timings."""
    if isinstance(value, dict):
        return {k: strip(v) for k, v in value.items() if not k.endswith("_us")}
    if isinstance(value, list):
        return [strip(v) for v in value]
    return value


def run(binary, scene, args):
    out = subprocess.run(
        [binary, "compare", scene, "--json", *args],
        check=True,
        capture_output=True,
        text=True,
    )
    return strip(json.loads(out.stdout))


def differences(a, b, path=""):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                yield f"{path}.{k}: only in {'after' if k in b else 'before'}"
            else:
                yield from differences(a[k], b[k], f"{path}.{k}")
    elif path.endswith(".events_bytes_per_tick") and isinstance(a, (int, float)):
        if abs(a - b) > 0.005 * max(abs(a), abs(b), 1.0):
            yield f"{path}: {a!r} before, {b!r} after (more than 0.5 %)"
    elif a != b:
        yield f"{path}: {a!r} before, {b!r} after"


def pair(old, new):
    """Each run with `old` and then `new`, compared."""
    for binary in (old, new):
        if not os.access(binary, os.X_OK):
            print(f"no seam binary at {binary}", file=sys.stderr)
            return 2
    runs = [(s, n, a) for s in scenes() for n, a in SETTINGS.items()]
    changed = 0
    for i, (scene, name, args) in enumerate(runs, 1):
        stem = os.path.splitext(os.path.basename(scene))[0]
        print(f"[{i}/{len(runs)}] {stem} {name}", file=sys.stderr, flush=True)
        diff = list(differences(run(old, scene, args), run(new, scene, args)))
        if diff:
            changed += 1
            print(f"{stem} {name}: {len(diff)} figures differ")
            for line in diff[:20]:
                print(f"  {line}")
    print(f"{len(runs) - changed} of {len(runs)} runs identical in every figure but timings")
    return 1 if changed else 0


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "pair":
        return pair(sys.argv[2], sys.argv[3])
    if len(sys.argv) != 3 or sys.argv[1] not in ("record", "check"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    mode, folder = sys.argv[1], sys.argv[2]
    binary = os.environ.get("SEAM_BIN", "target/release/seam")
    if not os.access(binary, os.X_OK):
        print(f"no seam binary at {binary}: build it or set SEAM_BIN", file=sys.stderr)
        return 2
    os.makedirs(folder, exist_ok=True)
    runs = [(s, n, a) for s in scenes() for n, a in SETTINGS.items()]
    changed = 0
    for i, (scene, name, args) in enumerate(runs, 1):
        stem = os.path.splitext(os.path.basename(scene))[0]
        path = os.path.join(folder, f"{stem}__{name}.json")
        print(f"[{i}/{len(runs)}] {stem} {name}", file=sys.stderr, flush=True)
        doc = run(binary, scene, args)
        if mode == "record":
            with open(path, "w") as f:
                json.dump(doc, f, indent=1, sort_keys=True)
            continue
        try:
            with open(path) as f:
                before = json.load(f)
        except FileNotFoundError:
            print(f"{stem} {name}: no recorded run at {path}")
            changed += 1
            continue
        diff = list(differences(before, doc))
        if diff:
            changed += 1
            print(f"{stem} {name}: {len(diff)} figures differ")
            for line in diff[:20]:
                print(f"  {line}")
    if mode == "check":
        print(f"{len(runs) - changed} of {len(runs)} runs identical in every figure but timings")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())
