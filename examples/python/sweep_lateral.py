"""The sand biaxial test at several lateral stresses, its peaks in a pandas table.

One sample, the biaxial test of examples/biaxial-sand-peak.toml at sigma_3 = 1, 2, 3 and
4 bar (each until the deviator falls 5% past its peak, or the increments run out), run
without result files; the peak of each, with the mobilised friction angle
phi' = asin((sigma_1 - sigma_3) / (sigma_1 + sigma_3)), goes into one DataFrame, written as
CSV.

    python examples/python/sweep_lateral.py --grains 1000 --increments 100
"""

import math

import pandas as pd

import grainstat
from common import arguments, biaxial_test

LATERAL = [1e5, 2e5, 3e5, 4e5]  # sigma_3 [Pa]


def peak(test: dict) -> dict:
    """Run `test` and return its peak deviator's row."""
    sim = grainstat.Simulation(test, output=False)
    best = None
    while not sim.finished:
        report = sim.step()
        if report is None:
            break
        s = report.measurements.macro_stress
        q = s[1, 1] - s[0, 0]
        if report.stage == 1 and (best is None or q > best["deviator"]):
            best = {"increment": report.increment, "sigma_1": s[1, 1], "sigma_3": s[0, 0],
                    "deviator": q}
    best["phi_deg"] = math.degrees(math.asin(best["deviator"] / (best["sigma_1"] + best["sigma_3"])))
    best["ended"] = sim.failure or "load program done"
    return best


def main() -> None:
    args = arguments(__doc__.splitlines()[0], grains=1000, increments=100)
    test, _ = biaxial_test(args)
    rows = []
    for sigma_3 in LATERAL:
        test["stages"][0]["stress"] = {"left": sigma_3, "right": sigma_3, "top": sigma_3}
        rows.append({"lateral_bar": sigma_3 / 1e5, **peak(test)})
    table = pd.DataFrame(rows).set_index("lateral_bar")
    path = args.out / "sweep-lateral.csv"
    table.to_csv(path)
    with pd.option_context("display.width", 160, "display.max_columns", None):
        print(table)
    print(path)


if __name__ == "__main__":
    main()
