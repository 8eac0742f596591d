"""Bad input raises the command line's message, with the file, the key and the line."""

import subprocess

import grainstat
import pytest

BAD = """name = "bad"

[material]
law = "linear"
normal_stiffness = 1e6
friction = -0.5
"""


def test_a_bad_scene_names_the_key_and_the_line():
    with pytest.raises(grainstat.InputError) as raised:
        grainstat.Scene.from_toml(BAD)
    e = raised.value
    assert (e.file, e.line, e.key) == ("<string>", 6, "material.friction")
    assert str(e).startswith("<string>:6: key `material.friction`: ")


def test_the_message_is_the_command_line_s(cli, tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(BAD)
    cli_run = subprocess.run([cli, "run", path, "--quiet"], capture_output=True, text=True)
    assert cli_run.returncode == 2
    with pytest.raises(grainstat.InputError) as raised:
        grainstat.Simulation(path)
    assert f"error: {raised.value}" == cli_run.stderr.strip()
    assert raised.value.line == 6 and str(path) in str(raised.value)


def test_a_bad_dict_names_the_key(root):
    scene = grainstat.Scene.from_file(root / "examples" / "crystal-biaxial.toml").to_dict()
    scene["material"]["poisson"] = "a lot"
    with pytest.raises(grainstat.InputError) as raised:
        grainstat.Scene.from_dict(scene)
    assert raised.value.key == "material.poisson" and raised.value.line is not None


def test_bad_solver_settings_name_the_key(root):
    with pytest.raises(grainstat.InputError) as raised:
        grainstat.Simulation(root / "examples" / "crystal-biaxial.toml", solver={"tolerence": 1e-9})
    assert raised.value.key == "tolerence"
    assert "tolerance" in grainstat.default_solver()


def test_a_missing_scene_file_is_bad_input(tmp_path):
    with pytest.raises(grainstat.InputError, match="cannot read the scene file"):
        grainstat.Scene.from_file(tmp_path / "none.toml")


def test_a_sample_scene_is_not_run(root):
    with pytest.raises(grainstat.InputError, match="this scene prepares a sample"):
        grainstat.Simulation(root / "examples" / "sample-sand.toml", output=False)


def test_a_value_toml_cannot_hold_is_a_type_error():
    with pytest.raises(TypeError, match="`material.law`"):
        grainstat.Scene.from_dict({"material": {"law": object()}})


def test_a_result_file_that_is_not_one_is_bad_input(tmp_path):
    path = tmp_path / "not.h5"
    path.write_bytes(b"not hdf5")
    with pytest.raises(grainstat.InputError):
        grainstat.Results(path)
