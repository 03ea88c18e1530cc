"""The one-line messages every library error becomes."""

from pathlib import Path

import numpy as np

from unseeable.errors import InputError


def test_a_long_array_value_is_cut_to_a_line():
    message = str(InputError("must be finite", field="image", value=np.arange(1000)))
    shown = message.split("(got ", 1)[1]
    assert message.startswith("image: must be finite (got array([")
    assert len(shown) <= 81 and shown.endswith("...)")


def test_a_long_path_value_is_shown_whole():
    deep = Path("/tmp") / ("a-folder-with-a-long-name/" * 6) / "estimate.json"
    assert len(str(deep)) > 150
    for value in (deep, str(deep)):
        message = str(InputError("cannot be written", field="--out", value=value))
        assert str(deep) in message and "..." not in message
