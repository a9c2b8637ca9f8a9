#!/usr/bin/env python3
"""Predicted against measured, one error source at a time (dev-only, not run by CI).

Reads campaign reports written by

    stewart simulate --runs 20 --duration 20 --only SOURCE --report only-SOURCE.json

and, for each parameter of the payload, compares the error the source actually caused over the
runs (root mean square of estimate - truth) with what each run's error budget predicted for that
source (root mean square of `error_budget[SOURCE]`). A source that moves a parameter by more than
a tenth of the full sigma (the `--full` campaign's mean reported sigma) must agree within a
factor of 2 (issue 12). Prints one Markdown table per source.

With `--floor floor.json`, a campaign on the same seeds in a world with every source off, each
run's error first loses that seed's error in the floor world: the estimator's own error in an
ideal world (the same in every one-source campaign, and not a source of the budget), so that the
measured column is the source's alone.

    python3 scripts/budget_check.py --full full.json --floor floor.json only-*.json
"""
import argparse
import json
import math
import re
import sys

PARAMS = [
    ("mass", lambda q: q["mass"]),
    ("com x", lambda q: q["com"][0]),
    ("com y", lambda q: q["com"][1]),
    ("com z", lambda q: q["com"][2]),
    ("J_C xx", lambda q: q["inertia_com"][0][0]),
    ("J_C yy", lambda q: q["inertia_com"][1][1]),
    ("J_C zz", lambda q: q["inertia_com"][2][2]),
    ("J_C xy", lambda q: q["inertia_com"][0][1]),
    ("J_C xz", lambda q: q["inertia_com"][0][2]),
    ("J_C yz", lambda q: q["inertia_com"][1][2]),
]


def rms(xs):
    return math.sqrt(sum(x * x for x in xs) / len(xs)) if xs else float("nan")


def line_of(report, source):
    """The budget's sigma of `source` in one run's report."""
    for line in report["error_budget"]:
        if line["source"] == source:
            return line["sigma"]
    sys.exit(f"no `{source}` line in the report's error_budget")


def source_of(path, campaign):
    only = campaign.get("only")
    if only:
        return only
    m = re.search(r"only-([a-z_]+)\.json$", path)
    if not m:
        sys.exit(f"{path}: no `only` in the report and no only-SOURCE.json name")
    return m.group(1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", help="campaign with every source on (its sigmas scale the 0.1 σ rule)")
    ap.add_argument("--floor", help="campaign with every source off, on the same seeds")
    ap.add_argument("campaigns", nargs="+")
    args = ap.parse_args()
    floor = {}
    if args.floor:
        for r in json.load(open(args.floor))["reports"]:
            floor[r["run"]["seed"]] = r
    full_sigma = None
    if args.full:
        full = json.load(open(args.full))
        full_sigma = [rms([get(r["sigma"]) for r in full["reports"]]) for _, get in PARAMS]
    failures = 0
    for path in args.campaigns:
        campaign = json.load(open(path))
        source = source_of(path, campaign)
        reports = campaign["reports"]
        print(f"\n### only `{source}` ({len(reports)} runs)\n")
        print("| parameter | measured rms error | predicted (budget) | ratio | full σ | checked |")
        print("|---|---|---|---|---|---|")
        for k, (name, get) in enumerate(PARAMS):
            def own(r):
                base = floor.get(r["run"]["seed"])
                off = get(base["estimate"]) - get(base["truth"]) if base else 0.0
                if args.floor and base is None:
                    sys.exit(f"{path}: seed {r['run']['seed']} is not in the floor campaign")
                return off

            errors = [get(r["estimate"]) - get(r["truth"]) - own(r) for r in reports]
            predicted = [get(line_of(r, source)) for r in reports]
            measured, pred = rms(errors), rms(predicted)
            ratio = measured / pred if pred > 0 else float("inf")
            sigma = full_sigma[k] if full_sigma else float("nan")
            relevant = full_sigma is not None and max(measured, pred) > 0.1 * sigma
            ok = "" if not relevant else ("yes" if 0.5 <= ratio <= 2.0 else "**no**")
            failures += ok == "**no**"
            print(f"| {name} | {measured:.3e} | {pred:.3e} | {ratio:.2f} | {sigma:.3e} | {ok} |")
    print(f"\n{failures} parameter(s) outside a factor of 2 where the source matters")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
