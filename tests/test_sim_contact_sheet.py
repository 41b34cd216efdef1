"""The contact sheet tiles images on a grid."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.viz.contact_sheet import contact_sheet, save_contact_sheet


def test_tiles_land_where_expected(tmp_path):
    ims = [np.full((10, 20, 3), k * 40, np.uint8) for k in range(5)]
    sheet = contact_sheet(ims, columns=2)
    assert sheet.shape == (3 * 14 + 4, 2 * 24 + 4, 3)
    assert np.all(sheet[4:14, 4:24] == 0) and np.all(sheet[4:14, 28:48] == 40)
    assert np.all(sheet[32:42, 4:24] == 160) and np.all(sheet[32:42, 28:48] == 255)  # empty cell stays white
    save_contact_sheet(ims, str(tmp_path / "s.png"), [f"#{k}" for k in range(5)], columns=3, title="t")
    assert (tmp_path / "s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_input():
    with pytest.raises(CompassInputError, match="at least one"):
        contact_sheet([])
    with pytest.raises(CompassInputError, match="same size"):
        contact_sheet([np.zeros((4, 4, 3), np.uint8), np.zeros((5, 4, 3), np.uint8)])
