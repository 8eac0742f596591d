"""A biaxial test on dense sand, stepped from Python, with its stress-strain plot.

The sides are held at 1 bar, the top pushed down at 0.02% of the height an increment
(examples/biaxial-sand-peak.toml on a sample of the size asked for); each increment's
deviator (sigma_1 - sigma_3, from the macro stress) and volumetric strain are read from its
report, and the curves drawn with matplotlib.

    python examples/python/biaxial.py --grains 1000 --increments 100
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import grainstat  # noqa: E402
from common import arguments, biaxial_test  # noqa: E402


def main() -> None:
    args = arguments(__doc__.splitlines()[0], grains=1000, increments=100)
    test, height = biaxial_test(args)

    sim = grainstat.Simulation(test, output=args.out / "biaxial.h5")
    top = sim.wall_names.index("top")
    start = sim.state.walls.position[top]  # where the sample's preparation left it
    strain, deviator, volume = [], [], []
    volume_0 = None
    while not sim.finished:
        report = sim.step()
        if report is None:  # the load has dropped past the peak: the test's end
            break
        m = report.measurements
        volume_0 = volume_0 or m.volume
        if report.stage == 1:
            strain.append((sim.state.walls.position[top] - start) / height)
            deviator.append(m.macro_stress[1, 1] - m.macro_stress[0, 0])
            volume.append(1 - m.volume / volume_0)
    sim.close()

    figure, (q, v) = plt.subplots(1, 2, figsize=(10, 4))
    q.plot([100 * e for e in strain], [d / 1e5 for d in deviator], marker=".")
    q.set(xlabel="axial strain [%]", ylabel="sigma_1 - sigma_3 [bar]", title="deviator")
    v.plot([100 * e for e in strain], [100 * e for e in volume], marker=".")
    v.set(xlabel="axial strain [%]", ylabel="volumetric strain [%] (compression +)",
          title="volume")
    figure.suptitle(f"biaxial test on {args.grains} grains of dense sand, sigma_3 = 1 bar")
    figure.tight_layout()
    path = args.out / "biaxial-stress-strain.png"
    figure.savefig(path, dpi=120)
    peak = max(range(len(deviator)), key=deviator.__getitem__)
    print(f"peak deviator {deviator[peak] / 1e5:.3f} bar at {100 * strain[peak]:.2f}% axial strain"
          f"{'; ' + sim.failure if sim.failure else ''}")
    print(path)


if __name__ == "__main__":
    main()
