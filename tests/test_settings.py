import pytest

from sloshrom import ConfigError, Tank, settings


def test_defaults_match_objects():
    cfg = settings.defaults()
    assert Tank.from_dict(cfg["tank"]) == Tank()
    assert cfg["rom"]["delays"] == 70 and cfg["rom"]["neurons"] == 35


def test_user_file_overrides_quick_and_defaults(tmp_path):
    p = tmp_path / "my.toml"
    p.write_text("[rom]\nneurons = 20\n[tank]\nfill = 0.25\n")
    cfg = settings.load(p, quick=True)
    assert cfg["rom"]["neurons"] == 20
    assert cfg["rom"]["delays"] == settings.QUICK["rom"]["delays"]
    assert cfg["tank"]["fill"] == 0.25


@pytest.mark.parametrize(
    "text, match",
    [
        ("[rom]\nneuron = 3\n", "unknown configuration key 'rom.neuron'"),
        ("[rom]\nneurons = 'many'\n", "'rom.neurons' must be a number"),
        ("rom = 3\n", "'rom' must be a table"),
        ("[rom]\nsweep = 1\n", "true or false"),
    ],
)
def test_bad_user_config(tmp_path, text, match):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ConfigError, match=match):
        settings.load(p)
