"""A GNSS whose latitude and longitude are swapped, or whose longitude or latitude has lost its
sign, is refused at load: its track is the mirror image of the DVL's dead reckoning
(docs/robustness.md, 'A GNSS track mirrored'; since 0.4.13: up to 0.4.12 the demo ran 3 933 km
off, exit 0)."""

from __future__ import annotations

import logging
import math
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest

from adaptnav.mission import MissionError, load_mission


def _gps(demo: Path, tmp_path: Path, case: str) -> Path:
    root = tmp_path / "mission"
    shutil.copytree(demo, root)
    df = pd.read_parquet(root / "gps.parquet")
    lat, lon = df["lat_rad"].copy(), df["lon_rad"].copy()
    df["lat_rad"], df["lon_rad"] = {
        "swapped": (lon, lat),
        "lon negated": (lat, -lon),
        "lat negated": (-lat, lon),
    }[case]
    df.to_parquet(root / "gps.parquet")
    return root


@pytest.mark.parametrize("case", ["swapped", "lon negated"])
def test_mirrored_gnss_coordinates_are_refused_naming_file_and_columns(
    demo: Path, tmp_path: Path, case: str
) -> None:
    with pytest.raises(MissionError) as err:
        load_mission(_gps(demo, tmp_path, case))
    text = str(err.value)
    assert text.startswith("gps.parquet: the GNSS track is the mirror image of the DVL's"), text
    assert "(lat_rad, lon_rad)" in text and "latitude and longitude swapped" in text, text
    assert "[sensors.gps] scale_check = false" in text, text
    assert err.value.file == "gps.parquet" and err.value.field == "lat_rad"


def test_a_mirrored_track_whose_first_fix_is_missing_is_refused(demo: Path, tmp_path: Path) -> None:
    """The fixes' local frame starts at the first finite fix (an empty or inf first one would
    leave no track to judge, and inf a RuntimeWarning)."""
    root = _gps(demo, tmp_path, "lon negated")
    df = pd.read_parquet(root / "gps.parquet")
    df.loc[0, "lat_rad"] = math.nan
    df.to_parquet(root / "gps.parquet")
    with pytest.raises(MissionError, match="the GNSS track is the mirror image"):
        load_mission(root)


def test_a_latitude_negated_or_a_gyro_z_negated_is_refused_naming_both(
    demo: Path, tmp_path: Path
) -> None:
    """A latitude negated mirrors the fixes, and a gyro z negated the dead reckoning; the
    gyro's earth rate at rest (-Ω sin L, 26.8° N: -3.3e-5 rad/s) then has the other
    hemisphere's sign against the fixes' latitude in both cases, so both are named."""
    gyro = tmp_path / "gyro"
    shutil.copytree(demo, gyro)
    imu = pd.read_parquet(gyro / "imu.parquet")
    imu["dtheta_z_rad"] = -imu["dtheta_z_rad"]
    imu.to_parquet(gyro / "imu.parquet")
    for root in (_gps(demo, tmp_path, "lat negated"), gyro):
        with pytest.raises(MissionError) as err:
            load_mission(root)
        text = str(err.value)
        assert text.startswith("imu.parquet: the gyro's z axis (dtheta_z_rad) or the latitude "
                               "of sensor 'gps' (gps.parquet, lat_rad)"), text  # fmt: skip
        found = re.search(r"vertical \(down\) earth rate of (\S+) rad/s where (\S+) ±", text)
        assert found is not None, text
        rate, expected = float(found[1]), float(found[2])
        # -Ω sin L at the fixes' latitude as read; the gyro reads the other sign.
        lat = -26.8 if root.name == "mission" else 26.8
        assert expected == pytest.approx(-7.292115e-5 * math.sin(math.radians(lat)), rel=0.01)
        assert rate * expected < 0.0 and 0.5 < abs(rate / expected) < 1.5, text
        assert err.value.file == "imu.parquet" and err.value.field == "dtheta_z_rad"


def test_a_right_gnss_or_one_unchecked_says_nothing(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    root = _gps(demo, tmp_path, "lon negated")
    toml = root / "mission.toml"
    text = toml.read_text()
    i = text.index("[sensors.gps]") + len("[sensors.gps]\n")
    toml.write_text(text[:i] + "scale_check = false\n" + text[i:])
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        load_mission(demo)
        load_mission(root)
    assert not [r for r in caplog.records if "mirror" in r.getMessage()]
