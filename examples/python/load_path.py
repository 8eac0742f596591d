"""A load path written in Python: the top stress of a sand sample cycled by a function of
the increment, the sides held at 1 bar.

Before each increment, `set_wall_stress` gives the top wall the stress
`top_stress(k)`: two cycles from 1 bar up to 2.5 bar and back. The stress path and the
axial strain it gives (with the loops friction draws) are plotted.

    python examples/python/load_path.py --grains 1000 --increments 80
"""

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import grainstat  # noqa: E402
from common import arguments, biaxial_test  # noqa: E402

SIDES = 1e5  # sigma_3 [Pa]


def top_stress(k: int, increments: int) -> float:
    """The top wall's stress after increment k [Pa]: two cycles between 1 and 2.5 bar."""
    return SIDES * (1 + 1.5 * math.sin(2 * math.pi * k / increments) ** 2)


def main() -> None:
    args = arguments(__doc__.splitlines()[0], grains=1000, increments=80)
    test, height = biaxial_test(args)
    # One stage of stress-controlled walls that the scene leaves where they are: the top's
    # stress comes from Python.
    test["stages"] = [{"name": "cycles", "increments": args.increments,
                       "stress": {"left": SIDES, "right": SIDES}}]
    sim = grainstat.Simulation(test, output=args.out / "load-path.h5")
    top = sim.wall_names.index("top")
    start = sim.state.walls.position[top]  # where the sample's preparation left it
    stress, strain = [], []
    for k in range(1, args.increments + 1):
        sim.set_wall_stress("top", top_stress(k, args.increments))
        report = sim.step()
        stress.append(report.measurements.wall_stress[top])
        strain.append((sim.state.walls.position[top] - start) / height)
    sim.close()

    figure, (path_axes, curve) = plt.subplots(1, 2, figsize=(10, 4))
    path_axes.plot(range(1, args.increments + 1), [s / 1e5 for s in stress], marker=".")
    path_axes.set(xlabel="increment", ylabel="sigma_top [bar]", title="the load path")
    curve.plot([100 * e for e in strain], [s / 1e5 for s in stress], marker=".")
    curve.set(xlabel="axial strain [%]", ylabel="sigma_top [bar]", title="stress against strain")
    figure.tight_layout()
    path = args.out / "load-path.png"
    figure.savefig(path, dpi=120)
    print(f"top stress {min(stress) / 1e5:.3f} to {max(stress) / 1e5:.3f} bar; "
          f"axial strain up to {100 * max(strain):.3f}%")
    print(path)


if __name__ == "__main__":
    main()
