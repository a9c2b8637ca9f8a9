#!/usr/bin/env python3
"""How far a campaign's mean z² may stray from 1 when every sigma is honest (dev-only, not run by CI).

A reported sigma rests on a few degrees of freedom ν of the residual windows (the report's
`covariance_basis.loaded_degrees_of_freedom`), and the estimator scales it by ν/(ν−2) so that
E[z²] = 1 (docs/accuracy.md, "Short measurements"). Then z = e/σ is a Student t scaled to unit
variance: heavy-tailed, so the mean of z² over a few runs is usually below 1 and now and then
far above it. This draws that mean by Monte Carlo for honest sigmas and prints its 95 % band.

    python3 scripts/z2_spread.py --runs 20 --nu 4 5 6 7 10 20
        the band of a 20-run mean z², and how often one quantity, or any of ten independent
        ones, falls outside [0.5, 2]

    python3 scripts/z2_spread.py campaign.json
        a campaign report (`stewart simulate --runs R --report campaign.json`): each quantity's
        mean z², its mean ν over the runs, and the 95 % band of an R-run mean z² at that ν

Only the standard library: `random.gammavariate` gives χ²_ν/2 draws.
"""
import argparse
import json
import random
import statistics

NAMES = ["mass", "com x", "com y", "com z", "J_C xx", "J_C yy", "J_C zz", "J_C xy", "J_C xz", "J_C yz"]


def mean_z2_draws(nu, runs, trials, rng):
    """Mean z² of `runs` honest runs, `trials` times: z = x / sqrt(χ²_ν/ν · ν/(ν−2))."""
    scale = nu / (nu - 2.0)
    draws = []
    for _ in range(trials):
        total = 0.0
        for _ in range(runs):
            x = rng.gauss(0.0, 1.0)
            c = 2.0 * rng.gammavariate(nu / 2.0, 1.0) / nu * scale
            total += x * x / c
        draws.append(total / runs)
    return sorted(draws)


def band(draws):
    n = len(draws)
    return draws[int(0.025 * n)], draws[int(0.975 * n) - 1]


def flat(q):
    j = q["inertia_com"]
    return [q["mass"], *q["com"], j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2]]


def campaign(path, trials, rng):
    reports = json.load(open(path))["reports"]
    runs = len(reports)
    print(f"{path}: {runs} runs")
    print("| quantity | mean z² | mean ν | 95 % band of an honest mean z² |")
    print("|---|---|---|---|")
    for k, name in enumerate(NAMES):
        z2 = []
        nus = []
        for r in reports:
            e = flat(r["estimate"])[k] - flat(r["truth"])[k]
            s = flat(r["sigma"])[k]
            z2.append((e / s) ** 2)
            nu = r["covariance_basis"]["loaded_degrees_of_freedom"][k]
            if nu is not None:
                nus.append(nu)
        nu = statistics.mean(nus) if nus else float("inf")
        if nu > 2.5 and nu < 1e6:
            lo, hi = band(mean_z2_draws(nu, runs, trials, rng))
            text = f"[{lo:.2f}, {hi:.2f}]"
        else:
            text = "—"
        print(f"| {name} | {statistics.mean(z2):.2f} | {nu:.1f} | {text} |")


def table(runs, nus, trials, rng):
    print(f"mean z² of {runs} honest runs ({trials} trials each)")
    print("| ν | 95 % band | P(outside [0.5, 2]) | P(below 0.5) | P(any of ten outside) |")
    print("|---|---|---|---|---|")
    for nu in nus:
        d = mean_z2_draws(nu, runs, trials, rng)
        lo, hi = band(d)
        out = sum(1 for v in d if v < 0.5 or v > 2.0) / len(d)
        low = sum(1 for v in d if v < 0.5) / len(d)
        print(f"| {nu:g} | [{lo:.2f}, {hi:.2f}] | {out:.3f} | {low:.3f} | {1 - (1 - out) ** 10:.2f} |")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("report", nargs="?", help="a campaign report (JSON)")
    p.add_argument("--runs", type=int, default=20)
    p.add_argument("--nu", type=float, nargs="+", default=[4, 5, 6, 7, 10, 20])
    p.add_argument("--trials", type=int, default=20000)
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args()
    rng = random.Random(a.seed)
    if a.report:
        campaign(a.report, a.trials, rng)
    else:
        table(a.runs, a.nu, a.trials, rng)


if __name__ == "__main__":
    main()
