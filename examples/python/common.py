"""What the examples share: a sand sample prepared as examples/sample-sand.toml says, at the
size asked for, and the scenes of the examples folder as dicts to change."""

import argparse
import pathlib

import grainstat

EXAMPLES = pathlib.Path(__file__).resolve().parents[1]


def arguments(description: str, grains: int, increments: int) -> argparse.Namespace:
    """The size of an example's run and where it writes."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--grains", type=int, default=grains, help="grains in the sample")
    parser.add_argument("--increments", type=int, default=increments, help="load increments")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("results/python"),
                        help="folder for the sample, result files, figures and tables")
    return parser.parse_args()


def scene(name: str) -> dict:
    """The scene examples/NAME.toml as a dict."""
    return grainstat.Scene.from_file(EXAMPLES / f"{name}.toml").to_dict()


def biaxial_test(args: argparse.Namespace) -> tuple[dict, float]:
    """examples/biaxial-sand-peak.toml on a dense sand sample of `args.grains` grains at 1 bar
    prepared in `args.out` (as examples/sample-sand.toml says), its biaxial stage
    `args.increments` increments of 0.02% of the height; and the sample's height [m]."""
    args.out.mkdir(parents=True, exist_ok=True)
    spec = scene("sample-sand")
    spec["sample"]["grains"] = args.grains
    path = args.out / f"sand-{args.grains}.h5"
    g = grainstat.generate(spec, path).state.grains
    height = float((g.position[:, 1] + g.radius).max() - (g.position[:, 1] - g.radius).min())
    test = scene("biaxial-sand-peak")
    test["grains"]["sample"] = str(path.resolve())
    biaxial = test["stages"][1]
    biaxial["increments"] = args.increments
    biaxial["displacement"]["top"] = 2e-4 * height * args.increments
    return test, height
