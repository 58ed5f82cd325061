"""NMEA 0183 import (docs/nmea.md): a simulated mission's GNSS and heading written as NMEA text
(checksums computed here, independently of pynmea2), imported back, and run.

* the published GGA/RMC example sentences read to their known values;
* the round trip: positions, heights, times and headings back to the NMEA resolution, the
  midnight roll-over and a log split in two files; a run on the imported mission matches the
  original's position RMSE;
* bad input: each kind of bad line in the repair log with its line and reason, the refusals
  (exit 2), and corrupted logs drawn by hypothesis that never end in a traceback nor drop a
  line silently.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import shutil
import time
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from adaptnav import api
from adaptnav.analysis import evaluate
from adaptnav.cli import app
from adaptnav.importers.nmea import NmeaError, fix_sigma, import_nmea, read_nmea
from adaptnav.mission import load_config, load_mission, write_config
from helpers import badinput

runner = CliRunner()

T0 = dt.datetime(2024, 3, 10, 23, 59, 30, tzinfo=dt.UTC)
"""UTC of the simulated mission's t_s = 0: midnight falls 30 s into it."""
MINUTE_DECIMALS = 7
"""Decimals of the minutes of latitude and longitude written (1e-7 min = 0.19 mm)."""
KNOT = 1852.0 / 3600.0
SEED = 16


# --- writing NMEA, independently of the importer -------------------------------------------------


def sentence(body: str) -> str:
    """``$body*hh``: the checksum is the XOR of the bytes between ``$`` and ``*``."""
    check = 0
    for byte in body.encode("ascii"):
        check ^= byte
    return f"${body}*{check:02X}"


def ddmm(deg: float, width: int, hemispheres: str) -> str:
    """Degrees → ``(d)ddmm.mmmmmmm,H`` with ``width`` degree digits."""
    a = abs(deg)
    d = int(a)
    m = round((a - d) * 60.0, MINUTE_DECIMALS)
    if m >= 60.0:
        d, m = d + 1, 0.0
    hemi = hemispheres[0] if deg >= 0 else hemispheres[1]
    return f"{d:0{width}d}{m:0{3 + MINUTE_DECIMALS}.{MINUTE_DECIMALS}f},{hemi}"


def utc_fields(t_s: float) -> tuple[str, str]:
    """(``hhmmss.ss``, ``ddmmyy``) of mission time ``t_s`` at :data:`T0`, to the centisecond."""
    cs = round((T0.timestamp() + t_s) * 100.0)
    when = dt.datetime.fromtimestamp(cs // 100, dt.UTC)
    return f"{when:%H%M%S}.{cs % 100:02d}", f"{when:%d%m%y}"


def epoch_lines(t: float, lat: float, lon: float, h: float, yaw: float, v: tuple[float, float]):
    """One epoch as a receiver writes it: RMC, GGA, HDT, VTG and a GSV (not used)."""
    hms, dmy = utc_fields(t)
    sog = math.hypot(*v) / KNOT
    cog = math.degrees(math.atan2(v[1], v[0])) % 360.0
    pos = f"{ddmm(math.degrees(lat), 2, 'NS')},{ddmm(math.degrees(lon), 3, 'EW')}"
    sep = 21.3
    return [
        sentence(f"GPRMC,{hms},A,{pos},{sog:.3f},{cog:.2f},{dmy},,,A"),
        sentence(f"GNGGA,{hms},{pos},1,09,1.4,{h - sep:.3f},M,{sep:.1f},M,,"),
        sentence(f"HEHDT,{math.degrees(yaw) % 360.0:.2f},T"),
        sentence(f"GPVTG,{cog:.2f},T,,M,{sog:.3f},N,{sog * 1.852:.3f},K,A"),
        sentence("GPGSV,3,1,11,03,03,111,00,04,15,270,00,06,01,010,00,13,06,292,00"),
    ]


# --- the simulated mission -----------------------------------------------------------------------


def _interp(t: np.ndarray, truth: pd.DataFrame, col: str) -> np.ndarray:
    values = truth[col].to_numpy()
    if col == "yaw_rad":
        values = np.unwrap(values)
    return np.interp(t, truth["t_s"].to_numpy(), values)


@pytest.fixture(scope="module")
def original(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny simulated mission with its GPS aiding (heights added) and a heading sensor at
    the GPS epochs (truth + 0.5° noise), both ``use = "aid"``."""
    root = badinput.tiny_mission(tmp_path_factory.mktemp("orig"), fmt="parquet")
    truth = pd.read_parquet(root / "truth.parquet")
    gps = pd.read_parquet(root / "gps.parquet")
    rng = np.random.default_rng(SEED)
    t = gps["t_s"].to_numpy()
    gps["h_m"] = _interp(t, truth, "h_m") + rng.normal(0.0, 3.0, t.size)
    yaw = _interp(t, truth, "yaw_rad") + rng.normal(0.0, math.radians(0.5), t.size)
    gps.to_parquet(root / "gps.parquet", index=False)
    pd.DataFrame({"t_s": t, "yaw_rad": yaw}).to_parquet(root / "heading.parquet", index=False)
    config = load_config(root / "mission.toml")
    sensors = dict(config.sensors)
    sensors["gps"] = sensors["gps"].model_copy(update={"use": "aid"})
    sensors["heading"] = sensors["heading"].model_copy(update={"use": "aid"})
    write_config(config.model_copy(update={"sensors": sensors}), root / "mission.toml")
    return root


@pytest.fixture(scope="module")
def logs(original: Path, tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """The original's GPS and heading as NMEA, split in two files after 35 epochs."""
    gps = pd.read_parquet(original / "gps.parquet")
    head = pd.read_parquet(original / "heading.parquet")
    truth = pd.read_parquet(original / "truth.parquet")
    t = gps["t_s"].to_numpy()
    vn, ve = _interp(t, truth, "vn_m_s"), _interp(t, truth, "ve_m_s")
    lines = [
        line
        for k in range(t.size)
        for line in epoch_lines(
            t[k], gps["lat_rad"][k], gps["lon_rad"][k], gps["h_m"][k], head["yaw_rad"][k],
            (vn[k], ve[k]),
        )
    ]  # fmt: skip
    folder = tmp_path_factory.mktemp("logs")
    cut = 35 * 5
    paths = [folder / "a.nmea", folder / "b.nmea"]
    paths[0].write_text("\r\n".join(lines[:cut]) + "\r\n", encoding="ascii")
    paths[1].write_text("\r\n".join(lines[cut:]) + "\r\n", encoding="ascii")
    return paths


def _import(original: Path, logs: list[Path], out: Path, *options: str) -> Path:
    """``adaptnav import nmea`` of ``logs`` onto ``original`` (fixes as ``gps``) into ``out``."""
    result = runner.invoke(
        app,
        ["import", "nmea", *map(str, logs), "--mission", str(original), "--t0-utc",
         T0.isoformat(), "--gnss-name", "gps", *options, "--out", str(out)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def imported(original: Path, logs: list[Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _import(original, logs, tmp_path_factory.mktemp("imp") / "mission", "--sigma-m", "2.915")


# --- known sentences -----------------------------------------------------------------------------


def test_published_example_sentences(tmp_path: Path) -> None:
    """The GGA and RMC examples of the NMEA literature (checksums 47 and 6A as published):
    48°07.038' N, 11°31.000' E, 545.4 m above the geoid which is 46.9 m above the ellipsoid,
    12:35:19 UTC on 23 March 1994, HDOP 0.9."""
    log = tmp_path / "example.nmea"
    log.write_text(
        "$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A\n"
        "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\n",
        encoding="ascii",
    )
    nmea = read_nmea([log], uere_m=4.0)
    fix = nmea.gnss.iloc[0]
    assert fix["utc_s"] == dt.datetime(1994, 3, 23, 12, 35, 19, tzinfo=dt.UTC).timestamp()
    assert math.degrees(fix["lat_rad"]) == pytest.approx(48.0 + 7.038 / 60.0, abs=1e-12)
    assert math.degrees(fix["lon_rad"]) == pytest.approx(11.0 + 31.0 / 60.0, abs=1e-12)
    assert fix["h_m"] == pytest.approx(545.4 + 46.9)
    # HDOP × UERE is the horizontal DRMS: 0.9 × 4 = 3.6 m, 2.546 m per axis; VDOP = 1.5 HDOP
    assert fix["sigma_n_m"] == pytest.approx(3.6 / math.sqrt(2.0))
    assert fix["sigma_d_m"] == pytest.approx(1.5 * 0.9 * 4.0)
    speed = nmea.velocity.iloc[0]
    assert speed["sog_m_s"] == pytest.approx(22.4 * 1852.0 / 3600.0)
    assert math.degrees(speed["cog_rad"]) == pytest.approx(84.4)
    assert nmea.repairs == ()


def test_rtk_sigmas_do_not_depend_on_hdop() -> None:
    assert fix_sigma(4, 9.9) == fix_sigma(4, 0.5) == (0.02, 0.02, 0.04)
    assert fix_sigma(2, 1.0, uere_m=10.0) == pytest.approx((1 / math.sqrt(2),) * 2 + (1.5,))


# --- round trip ----------------------------------------------------------------------------------


def test_round_trip_to_the_nmea_resolution(original: Path, imported: Path) -> None:
    gps = pd.read_parquet(original / "gps.parquet")
    head = pd.read_parquet(original / "heading.parquet")
    got = pd.read_parquet(imported / "gps.parquet")
    got_head = pd.read_parquet(imported / "heading.parquet")
    assert len(got) == len(gps) and len(got_head) == len(head)
    minute = math.radians(1.0 / 60.0)
    assert np.abs(got["t_s"] - gps["t_s"]).max() <= 0.005 + 1e-6  # centiseconds
    assert np.abs(got["lat_rad"] - gps["lat_rad"]).max() <= 0.5e-7 * minute * 1.001
    assert np.abs(got["lon_rad"] - gps["lon_rad"]).max() <= 0.5e-7 * minute * 1.001
    assert np.abs(got["h_m"] - gps["h_m"]).max() <= 0.0005 + 1e-9  # mm altitude, 0.1 m sep exact
    dyaw = np.angle(np.exp(1j * (got_head["yaw_rad"] - head["yaw_rad"])))
    assert np.abs(dyaw).max() <= math.radians(0.005) * 1.001
    np.testing.assert_array_equal(got_head["t_s"], got["t_s"])  # HDT: the GGA's time
    info = json.loads((imported / "import.json").read_text(encoding="utf-8"))
    assert info["time"]["midnight_rollovers"] == 1
    assert info["repairs"] == []
    assert info["sentences_ignored"] == {"GSV": len(gps)}
    assert info["gnss"]["by_quality"] == {"GPS (SPS)": len(gps)}


def test_imported_mission_keeps_the_replaced_sections(original: Path, imported: Path) -> None:
    before, after = load_config(original / "mission.toml"), load_config(imported / "mission.toml")
    assert after.sensors["gps"].lever_arm_m == before.sensors["gps"].lever_arm_m
    assert after.sensors["heading"].sigma == before.sensors["heading"].sigma
    assert after.sensors["gps"].sigma == ([2.915, 2.915], "m")  # N, E: no height
    assert after.sensors.keys() == before.sensors.keys()
    assert (imported / "gps_velocity.parquet").is_file()


def test_a_t0_without_a_zone_is_utc_in_the_api(
    logs: list[Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``import_nmea(t0_utc=datetime(...))`` without a zone: UTC, as the CLI takes
    ``--t0-utc``. Up to 0.4.7 ``.timestamp()`` read it in the machine's zone: on a laptop in
    Tehran (UTC+3:30) every fix 12600 s off, exit 0 without --mission."""
    monkeypatch.setenv("TZ", "Asia/Tehran")
    time.tzset()
    try:
        out = import_nmea(logs, tmp_path / "o", t0_utc=T0.replace(tzinfo=None))
    finally:
        monkeypatch.delenv("TZ")
        time.tzset()
    info = json.loads((out / "import.json").read_text(encoding="utf-8"))
    assert info["time"]["t0_utc"] == T0.isoformat()
    gnss = pd.read_parquet(out / "gnss.parquet")
    np.testing.assert_allclose(gnss["t_s"], gnss["utc_s"] - T0.timestamp())


def test_min_interval_s_goes_into_the_gnss_section(
    original: Path, logs: list[Path], tmp_path: Path
) -> None:
    """``--min-interval-s 30`` writes ``min_interval_s = 30`` into ``[sensors.gps]``, and the
    mission then keeps fixes at least 30 s apart (on the code before, the option did not
    exist)."""
    m = load_mission(_import(original, logs, tmp_path / "m", "--min-interval-s", "30"))
    assert m.config.sensors["gps"].min_interval_s == 30.0
    assert np.diff(m.sensors["gps"].t).min() >= 30.0
    assert any(d.reason.startswith("thinned: ") for d in m.dropped)


def test_a_replaced_compass_loses_its_declination(
    original: Path, logs: list[Path], tmp_path: Path
) -> None:
    """The mission's heading sensor was a magnetic compass (``declination_deg = 7``): the HDT
    headings that replace it are true, so the section keeps its other keys but not the
    declination, which the loader would add to them (kept, every heading would be 7° off)."""
    mission = tmp_path / "compass"
    shutil.copytree(original, mission)
    config = load_config(mission / "mission.toml")
    sensors = dict(config.sensors)
    sensors["heading"] = sensors["heading"].model_copy(update={"declination_deg": 7.0})
    write_config(config.model_copy(update={"sensors": sensors}), mission / "mission.toml")
    assert load_config(mission / "mission.toml").sensors["heading"].declination_deg == 7.0
    m = load_mission(_import(mission, logs, tmp_path / "m"))
    assert m.config.sensors["heading"].declination_deg is None
    assert m.config.sensors["heading"].sigma == config.sensors["heading"].sigma
    got = m.sensors["heading"].z[:, 0]
    want = pd.read_parquet(original / "heading.parquet")["yaw_rad"].to_numpy()
    np.testing.assert_allclose(np.angle(np.exp(1j * (got - want))), 0.0, atol=1e-4)


def test_run_on_the_imported_mission_matches_the_original(original: Path, imported: Path) -> None:
    """Same fixes to 0.2 mm and 5 ms, same σ: the position RMSE agrees within 1 % (a t0 off
    by 1 s moves it by 4 %)."""
    rmse = {}
    for name, root in (("original", original), ("imported", imported)):
        m = load_mission(root)
        errors = evaluate.position_errors(api.run(m, "meskf").solution, m.truth)
        rmse[name] = evaluate.rmse(errors)
    assert rmse["imported"] == pytest.approx(rmse["original"], rel=0.01), rmse


# --- bad input -----------------------------------------------------------------------------------


def _good_epochs(n: int, start_s: float = 10.0) -> list[str]:
    """n epochs of a track heading north-east at 2 m/s from 26.8° N, 56.0° E."""
    out = []
    for k in range(n):
        t = start_s + k
        lat = math.radians(26.8) + 2.0 * t * math.cos(0.8) / 6.37e6
        lon = math.radians(56.0) + 2.0 * t * math.sin(0.8) / (6.37e6 * math.cos(0.47))
        out += epoch_lines(t, lat, lon, 10.0, 0.8, (2 * math.cos(0.8), 2 * math.sin(0.8)))[:4]
    return out


def test_each_bad_line_is_repaired_with_its_reason(tmp_path: Path) -> None:
    """Epochs of RMC, GGA, HDT, VTG after a leading HDT (file line = index + 2): the GGA of
    each of the first five epochs spoilt one way, the last GGA repeated at the end."""
    lines = _good_epochs(8)
    hms, _ = utc_fields(12.0)
    lines[1] = lines[1][:-2] + ("00" if lines[1][-2:] != "00" else "01")  # line 3: checksum
    lines[5] = lines[5][:30]  # line 7: cut short, no checksum
    lines[9] = sentence(f"GPGGA,{hms},,,,,0,00,99.9,,M,,M,,")  # line 11: no fix
    lines[13] = "\x00\x9f\xff garbage"  # line 15: binary
    lines[17] = sentence("GPXYZ,1,2,3")  # line 19: unknown sentence type
    lines.append(lines[29])  # line 34: the last epoch's GGA again: time does not increase
    log = tmp_path / "bad.nmea"
    log.write_bytes(("\n".join([sentence("HEHDT,10.0,T"), *lines]) + "\n").encode("latin-1"))
    nmea = read_nmea([log])
    got = {(r.line, r.action) for r in nmea.repairs}
    assert got == {
        (1, "no time"),
        (3, "checksum mismatch"),
        (7, "no checksum"),
        (11, "fix invalid"),
        (15, "not ASCII text"),
        (19, "unknown sentence type"),
        (34, "time does not increase"),
    }
    assert nmea.gnss["nmea_line"].tolist() == [23, 27, 31]
    assert len(nmea.heading) == 8 and len(nmea.velocity) == 16


def _with_field(line: str, index: int, text: str) -> str:
    """The sentence with field ``index`` (0: the address) set to ``text``, checksum anew."""
    fields = line[1:].partition("*")[0].split(",")
    fields[index] = text
    return sentence(",".join(fields))


def test_a_heading_after_a_fix_with_a_bad_field_takes_that_fixs_time(tmp_path: Path) -> None:
    """GGA and HDT only: the GGA of 12 s has no altitude (a repair) and the HDT of 11 s is
    missing. The HDT of 12 s follows the bad GGA, whose time is good: it is stamped 12 s (up
    to 0.4.4 the bad GGA's time went with it, and that heading took 11 s, silently)."""
    lines = [line for line in _good_epochs(4) if line[3:6] in ("GGA", "HDT")]
    lines[4] = _with_field(lines[4], 9, "")  # the GGA of 12 s (line 5): no altitude
    del lines[3]  # the HDT of 11 s
    log = tmp_path / "gga-hdt.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    nmea = read_nmea([log], date=dt.date(2024, 3, 10))
    assert {(r.line, r.field, r.action) for r in nmea.repairs} == {(4, "altitude", "empty field")}
    t0 = T0.timestamp()
    np.testing.assert_allclose(nmea.heading["utc_s"] - t0, [10.0, 12.0, 13.0], atol=1e-6)
    np.testing.assert_allclose(nmea.gnss["utc_s"] - t0, [10.0, 11.0, 13.0], atol=1e-6)


def test_two_talkers_interleaved_are_two_sources(tmp_path: Path) -> None:
    """A multiplexed log: receiver A ($GPGGA at whole seconds) and receiver B ($GNGGA half a
    second later, its antenna 20 m east), a gyro ($HEHDT, 30°) and a GNSS compass ($GPHDT,
    31°) after each GGA. Up to 0.4.7 both receivers' fixes made one track at 2 Hz jumping
    20 m back and forth, and the headings the first after each GGA, exit 0. The import is
    refused, naming the talkers and the option; with it, one source, the others repairs.
    A receiver that switches talker (GP, then GN) is one source."""
    lines = [sentence("GPZDA,000000.00,10,03,2024,00,00")]
    for k in range(1, 9):
        for talker, frac, east, hdt in (("GP", "00", 0.0, "HEHDT,30.0,T"),
                                        ("GN", "50", 20.0, "GPHDT,31.0,T")):  # fmt: skip
            lon = 56.0 + east / (6378137.0 * math.cos(math.radians(26.8))) * 180.0 / math.pi
            pos = f"{ddmm(26.8, 2, 'NS')},{ddmm(lon, 3, 'EW')}"
            lines += [sentence(f"{talker}GGA,0000{k:02d}.{frac},{pos},1,09,1.0,5.0,M,20.0,M,,"),
                      sentence(hdt)]  # fmt: skip
    log = tmp_path / "mux.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    with pytest.raises(NmeaError, match=r"GGA sentences of 2 talkers interleave.*--gnss-talker"):
        read_nmea([log])
    with pytest.raises(NmeaError, match=r"HDT sentences of 2 talkers interleave.*--heading-talker"):
        read_nmea([log], talkers={"GGA": "GN"})
    nmea = read_nmea([log], talkers={"GGA": "gn", "HDT": "HE"})
    assert len(nmea.gnss) == 8 and nmea.gnss["nmea_line"].tolist() == list(range(4, 34, 4))
    np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), 30.0)
    assert {r.action for r in nmea.repairs} == {"another talker"} and len(nmea.repairs) == 16
    switched = [line for line in lines if "GN" not in line[:3] and "GPHDT" not in line]
    switched = switched[:9] + [line.replace("$GPGGA", "$GNGGA") for line in switched[9:]]
    log.write_text("\n".join(sentence(s[1:].partition("*")[0]) for s in switched) + "\n")
    assert len(read_nmea([log]).gnss) == 8
    code = runner.invoke(app, ["import", "nmea", str(log), "--out", str(tmp_path / "o"),
                               "--gnss-talker", "XX"]).exit_code  # fmt: skip
    assert code == 2 and not (tmp_path / "o").exists()


def test_rmc_and_vtg_of_two_talkers_interleaved_are_two_receivers(tmp_path: Path) -> None:
    """Two receivers' RMC and VTG (GP at whole seconds, 2 kn to 045°; GN half a second later,
    4 kn to 090°) beside one receiver's GGA: the velocity table would alternate between them,
    so the import is refused naming the talkers and --gnss-talker, which chooses the receiver
    of the GGA, RMC and VTG; the other's RMC and VTG are repairs ("another talker"), their
    dates and times still counted. Up to 0.4.8 both were read: 16 rows of 2 and 4 kn."""
    pos = f"{ddmm(26.8, 2, 'NS')},{ddmm(56.0, 3, 'EW')}"
    lines = []
    for k in range(1, 5):
        lines += [sentence(f"GNGGA,0000{k:02d}.00,{pos},1,09,1.0,5.0,M,20.0,M,,")]
        for talker, frac, kn, course in (("GP", "00", 2.0, 45.0), ("GN", "50", 4.0, 90.0)):
            lines += [sentence(f"{talker}RMC,0000{k:02d}.{frac},A,{pos},{kn},{course},100324,,,A"),
                      sentence(f"{talker}VTG,{course},T,,M,{kn},N,,K,A")]  # fmt: skip
    log = tmp_path / "two-rx.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    said = r"RMC sentences of 2 talkers interleave \(GP RMC from line 2 of two-rx.nmea, GN RMC"
    with pytest.raises(NmeaError, match=said + r" from line 4.*--gnss-talker"):
        read_nmea([log])
    nmea = read_nmea([log], talkers={"GGA": "GN"})
    assert len(nmea.velocity) == 8 and len(nmea.gnss) == 4
    np.testing.assert_allclose(nmea.velocity["sog_m_s"], 4.0 * KNOT)
    np.testing.assert_allclose(nmea.velocity["cog_rad"], math.radians(90.0))
    gp = sorted(5 * k + j for k in range(4) for j in (2, 3))  # GPRMC, GPVTG of each epoch
    assert [(r.line, r.action) for r in nmea.repairs] == [(n, "another talker") for n in gp]
    assert nmea.repairs[0].detail == "GPRMC, not the --gnss-talker GN"
    assert nmea.date_source == "RMC (two-rx.nmea line 2)"  # GP's RMC still dates the log


def test_one_receiver_sending_rmc_and_vtg_under_two_talkers_is_read(tmp_path: Path) -> None:
    """One receiver sending ``GNGGA``, ``GNRMC`` and ``GPVTG`` each second (a multi-GNSS
    receiver naming its VTG by GPS) is one source of speed and course: each sentence kind has
    one talker, so nothing interleaves and both series are read (8 rows: 4 RMC, 4 VTG). The
    first version of the RMC/VTG talker check took RMC and VTG as one source and refused it."""
    pos = f"{ddmm(26.8, 2, 'NS')},{ddmm(56.0, 3, 'EW')}"
    lines = []
    for k in range(1, 5):
        lines += [sentence(f"GNGGA,0000{k:02d}.00,{pos},1,09,1.0,5.0,M,20.0,M,,"),
                  sentence(f"GNRMC,0000{k:02d}.00,A,{pos},2.0,45.0,100324,,,A"),
                  sentence("GPVTG,45.0,T,,M,2.0,N,,K,A")]  # fmt: skip
    log = tmp_path / "one-rx.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    nmea = read_nmea([log])
    assert sorted(nmea.velocity["sentence"]) == ["RMC"] * 4 + ["VTG"] * 4
    np.testing.assert_allclose(nmea.velocity["sog_m_s"], 2.0 * KNOT)
    assert nmea.repairs == ()


def _with_headings(headings: list[list[str]]) -> list[str]:
    """The RMC and GGA of :func:`_good_epochs` (10 s on, file lines 1, 2 of each epoch), each
    epoch followed by its heading sentences (bodies, checksums added here)."""
    lines = [line for line in _good_epochs(len(headings)) if line[3:6] in ("RMC", "GGA")]
    out = []
    for k, bodies in enumerate(headings):
        out += [*lines[2 * k : 2 * k + 2], *map(sentence, bodies)]
    return out


def _placed(nmea, lines: list[str]) -> None:
    """Every line is in a table, in the repair log, or counted among the ignored sentences."""
    placed = {r.line for r in nmea.repairs}
    for table in (nmea.gnss, nmea.heading, nmea.velocity):
        placed |= set(table["nmea_line"].tolist())
    assert len(placed) + sum(nmea.ignored.values()) == len(lines)


def test_ths_gives_the_heading_table_of_its_mode_a_sentences(tmp_path: Path) -> None:
    """THS (IEC 61162-1 true heading and status), which pynmea2 does not know: mode A is a
    heading at the time of the GGA before it; E (dead reckoning), M, S are not measurements,
    V is void, a mode not in the standard is a bad field (up to 0.4.7 every THS was an
    "unknown sentence type": a gyro sending THS alone gave no heading)."""
    assert sentence("HETHS,316.70,E") == "$HETHS,316.70,E*1A"  # a published example
    modes = [("10.50", "A"), ("359.99", "A"), ("", "V"), ("20.0", "E"), ("30.0", "M"),
             ("40.0", "S"), ("0.00", "A"), ("50.0", "X"), ("400.0", "A")]  # fmt: skip
    lines = _with_headings([[f"HETHS,{h},{m}"] for h, m in modes])
    log = tmp_path / "ths.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    nmea = read_nmea([log])
    np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), [10.5, 359.99, 0.0])
    np.testing.assert_allclose(nmea.heading["utc_s"] - T0.timestamp(), [10.0, 11.0, 16.0])
    assert nmea.heading["nmea_line"].tolist() == [3, 6, 21]
    assert [(r.line, r.field, r.action) for r in nmea.repairs] == [
        (9, "mode", "void"), (12, "mode", "not a measurement"),
        (15, "mode", "not a measurement"), (18, "mode", "not a measurement"),
        (24, "mode", "bad field"), (27, "heading", "bad field"),
    ]  # fmt: skip
    assert "THS mode E (estimated (dead reckoning))" in nmea.repairs[1].detail
    assert nmea.sentences["THS"] == 7
    _placed(nmea, lines)
    result = runner.invoke(app, ["import", "nmea", str(log), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert len(pd.read_parquet(tmp_path / "o" / "heading.parquet")) == 3


def test_a_talker_sending_hdt_and_ths_gives_its_ths(tmp_path: Path) -> None:
    """A gyro that sends HDT (for older listeners) and THS at each epoch is one source: the
    THS are read, with their mode, and the HDT counted as ignored. The HDT beside a THS of
    mode V is not taken in its place (the device says the heading is not valid). HDT here
    read 99° to tell them apart; up to 0.4.7 the HDT were read and THS unknown."""
    ths = [("12.0", "A"), ("13.0", "A"), ("", "V"), ("15.0", "A")]
    lines = _with_headings([["HEHDT,99.0,T", f"HETHS,{h},{m}"] for h, m in ths])
    log = tmp_path / "both.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    nmea = read_nmea([log])
    np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), [12.0, 13.0, 15.0])
    np.testing.assert_allclose(nmea.heading["utc_s"] - T0.timestamp(), [10.0, 11.0, 13.0])
    assert [(r.line, r.action) for r in nmea.repairs] == [(12, "void")]
    assert nmea.ignored == {"HDT (its talker's THS at that time is read)": 4}
    _placed(nmea, lines)


def test_a_talker_sending_hdt_faster_than_ths_keeps_every_heading_once(tmp_path: Path) -> None:
    """A gyro sending HDT at every epoch and THS at every other: each epoch's heading is read
    once, the THS where both have the time (in either order; the HDT beside it ignored, also
    where the THS says V) and the HDT at the other epochs. A second HDT at one time is a
    repair, as any repeated time. Up to 0.4.8 every HDT of a talker sending THS was ignored:
    the heading table held only the THS epochs, 10 and 12 here, the rest lost silently."""
    epochs = [
        ["HEHDT,99.0,T", "HETHS,10.0,A"], ["HEHDT,11.0,T"], ["HETHS,12.0,A", "HEHDT,99.0,T"],
        ["HEHDT,13.0,T"], ["HEHDT,99.0,T", "HETHS,,V"], ["HEHDT,15.0,T", "HEHDT,15.5,T"],
    ]  # fmt: skip
    lines = _with_headings(epochs)
    log = tmp_path / "fast-hdt.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    nmea = read_nmea([log])
    np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), [10, 11, 12, 13, 15])
    np.testing.assert_allclose(nmea.heading["utc_s"] - T0.timestamp(), [10, 11, 12, 13, 15])
    assert nmea.heading["nmea_line"].tolist() == [4, 7, 10, 14, 21]
    repairs = [(18, "void"), (22, "time does not increase")]
    assert [(r.line, r.action) for r in nmea.repairs] == repairs
    assert nmea.ignored == {"HDT (its talker's THS at that time is read)": 3}
    _placed(nmea, lines)


def test_hdt_and_ths_of_two_talkers_interleaved_are_two_sources(tmp_path: Path) -> None:
    """A GNSS compass's $GPHDT beside a gyro's $HETHS: two headings, refused naming both; with
    --heading-talker one is read, the other's sentences "another talker"."""
    lines = _with_headings([["GPHDT,31.0,T", "HETHS,30.0,A"]] * 3)
    log = tmp_path / "two.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    said = r"HDT/THS sentences of 2 talkers interleave \(GP HDT from line 3 of two.nmea, HE THS"
    with pytest.raises(NmeaError, match=said + r" from line 4.*--heading-talker"):
        read_nmea([log])
    for talker, heading, other in (("HE", 30.0, 3), ("GP", 31.0, 4)):
        nmea = read_nmea([log], talkers={"HDT": talker})
        np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), heading)
        assert [(r.line, r.action) for r in nmea.repairs] == [
            (other + 4 * k, "another talker") for k in range(3)
        ]


def test_hdg_is_turned_to_true_north_by_its_deviation_and_variation(tmp_path: Path) -> None:
    """HDG (magnetic compass): true = sensor heading + deviation + variation, each E positive
    and W negative, wrapped to [0, 360); an empty deviation is 0. An HDG without variation
    among others with one is a repair, as a direction letter not E or W (up to 0.4.7 every
    HDG was ignored: a compass gave no heading)."""
    assert sentence("HCHDG,101.1,,,7.1,W") == "$HCHDG,101.1,,,7.1,W*3C"  # published example
    fields = ["100.0,1.0,E,3.2,W", "100.0,1.0,W,3.2,E", "359.0,,,2.5,E", "1.0,2.0,W,0.5,W",
              "101.1,,,7.1,W", "50.0,1.0,E,,", "50.0,1.0,X,3.0,E", "50.0,1.0,E,3.0,",
              "50.0,1.0,E,-3.0,W"]  # fmt: skip
    lines = _with_headings([[f"HCHDG,{f}"] for f in fields])
    log = tmp_path / "hdg.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    nmea = read_nmea([log])
    want = [100.0 + 1.0 - 3.2, 100.0 - 1.0 + 3.2, 1.5, 358.5, 94.0]
    np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), want, atol=1e-9)
    np.testing.assert_allclose(nmea.heading["utc_s"] - T0.timestamp(), 10.0 + np.arange(5))
    assert [(r.line, r.field, r.action) for r in nmea.repairs] == [
        (18, "variation", "no variation"), (21, "dev_dir", "bad field"),
        (24, "var_dir", "bad field"), (27, "variation", "bad field"),
    ]  # fmt: skip
    assert nmea.declination_deg is None and nmea.heading_sentences == ("HDG",)
    _placed(nmea, lines)
    result = runner.invoke(app, ["import", "nmea", str(log), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    section = tomllib.loads((tmp_path / "o" / "sensors.toml").read_text())["sensors"]["heading"]
    assert section["sigma"] == [2.0, "deg"] and "declination_deg" not in section


def test_hdg_without_variation_needs_the_declination(tmp_path: Path, original: Path) -> None:
    """A compass that gives no variation: no true heading can be formed, so the import is
    refused, naming --declination-deg. With it the table keeps the magnetic headings
    (sensor + deviation) and the heading section gets ``declination_deg``, which the loader
    adds (docs/data-format.md, 'Magnetic headings'). The option beside true headings (HDT)
    is refused: they would be turned twice."""
    lines = _with_headings([[f"HCHDG,{10.0 * k:.1f},1.0,W,,"] for k in range(6)])
    log = tmp_path / "compass.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    with pytest.raises(NmeaError, match=r"HDG headings \(6, from line 3\) give no variation"):
        read_nmea([log])
    args = ["import", "nmea", str(log), "--mission", str(original), "--t0-utc", T0.isoformat(),
            "--gnss-name", "gps"]  # fmt: skip
    result = runner.invoke(app, [*args, "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "--declination-deg D" in " ".join(result.output.split())
    result = runner.invoke(app, [*args, "--declination-deg", "-4.5", "--out", str(tmp_path / "m")])
    assert result.exit_code == 0, result.output
    table = pd.read_parquet(tmp_path / "m" / "heading.parquet")
    magnetic = (10.0 * np.arange(6) - 1.0) % 360.0
    np.testing.assert_allclose(np.degrees(table["yaw_rad"]), magnetic)
    m = load_mission(tmp_path / "m")
    assert m.config.sensors["heading"].declination_deg == -4.5
    true = np.radians(magnetic - 4.5)
    np.testing.assert_allclose(np.angle(np.exp(1j * (m.sensors["heading"].z[:, 0] - true))), 0.0,
                               atol=1e-12)  # fmt: skip
    info = json.loads((tmp_path / "m" / "import.json").read_text())
    assert info["heading"]["north"] == "magnetic north, declination_deg -4.5 in the section"
    hdt = tmp_path / "hdt.nmea"
    hdt.write_text("\n".join(_good_epochs(3)) + "\n", encoding="ascii")
    with pytest.raises(NmeaError, match="--declination-deg 3: no HDG heading read"):
        read_nmea([hdt], declination_deg=3.0)
    with pytest.raises(NmeaError, match=r"--declination-deg 95.0: must be within \[-90, 90\]"):
        read_nmea([log], declination_deg=95.0)


def test_hdm_is_a_magnetic_heading_that_needs_the_declination(tmp_path: Path) -> None:
    """HDM (an older compass sentence: the magnetic heading alone): no variation, so refused
    without --declination-deg, kept magnetic with it (up to 0.4.7 HDM was ignored: a compass
    that sends only HDM gave no heading). One not marked M is a bad field; beside an HDT it
    is ignored, as an HDG is."""
    lines = _with_headings([[f"HCHDM,{10.0 * k + 5.0:.1f},M"] for k in range(5)])
    log = tmp_path / "hdm.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    with pytest.raises(NmeaError, match=r"HDM headings \(5, from line 3\) give no variation"):
        read_nmea([log])
    nmea = read_nmea([log], declination_deg=-4.5)
    np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), 10.0 * np.arange(5) + 5.0)
    assert nmea.declination_deg == -4.5 and nmea.heading_sentences == ("HDM",)
    bad = tmp_path / "bad.nmea"
    bad.write_text("\n".join(_with_headings([["HCHDM,20.0,T"]] * 2)) + "\n", encoding="ascii")
    nmea = read_nmea([bad])
    assert nmea.heading.empty
    assert [(r.field, r.action) for r in nmea.repairs] == [("magnetic", "bad field")] * 2
    both = tmp_path / "both.nmea"
    both.write_text("\n".join(_with_headings([["HEHDT,30.0,T", "HCHDM,33.0,M"]] * 3)) + "\n",
                    encoding="ascii")  # fmt: skip
    nmea = read_nmea([both])
    np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), 30.0)
    assert nmea.ignored == {"HDM (a true heading, HDT or THS, is read)": 3}


def test_a_true_heading_beside_hdg_is_read_as_up_to_0_4_8(tmp_path: Path) -> None:
    """A gyro ($HEHDT) beside a magnetic compass ($HCHDG): the true heading is read as before
    and the HDG counted as ignored, not two interleaved sources. --heading-talker HC chooses
    the compass: its HDG, true by its variation, and the HDT "another talker"."""
    lines = _with_headings([["HEHDT,30.0,T", "HCHDG,33.0,0.5,E,2.0,W"]] * 3)
    log = tmp_path / "gyro-compass.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    nmea = read_nmea([log])
    np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), 30.0)
    assert nmea.repairs == () and nmea.ignored == {"HDG (a true heading, HDT or THS, is read)": 3}
    nmea = read_nmea([log], talkers={"HDT": "HC"})
    np.testing.assert_allclose(np.degrees(nmea.heading["yaw_rad"]), 31.5)
    assert [(r.line, r.action) for r in nmea.repairs] == [(3, "another talker"),
                                                          (7, "another talker"),
                                                          (11, "another talker")]  # fmt: skip


@pytest.mark.parametrize(
    ("kind", "index", "text", "field", "detail"),
    [
        ("RMC", 7, "-5.0", "spd_over_grnd", "outside [0, inf]"),
        ("RMC", 8, "400.0", "true_course", "outside [0, 360]"),
        ("VTG", 1, "361", "true_track", "outside [0, 360]"),
        ("VTG", 7, "-3.0", "spd_over_grnd_kmph", "outside [0, inf]"),
        ("GGA", 7, "-3", "num_sats", "outside [0, inf]"),
        ("GGA", 7, "7.5", "num_sats", "is not a count"),
        ("GGA", 8, "-1.2", "horizontal_dil", "outside [0, inf]"),
        ("GGA", 10, "F", "altitude_units", "heights in metres (M) only"),
        ("GGA", 9, "1_000", "altitude", "is not a number"),
        ("GGA", 9, "1e3", "altitude", "is not a number"),
        ("GGA", 9, "inf", "altitude", "is not a number"),
    ],
)
def test_a_field_out_of_its_range_is_a_repair(
    tmp_path: Path, kind: str, index: int, text: str, field: str, detail: str
) -> None:
    """Numbers Python's float takes but NMEA does not write, and values no receiver gives: the
    sentence goes to the repair log with its field (up to 0.4.4 kept: a negative speed, a
    course of 400°, -3 satellites, a height in feet read as metres)."""
    lines = _good_epochs(3)
    k = next(i for i, line in enumerate(lines) if line[3:6] == kind and i > 3)
    lines[k] = _with_field(lines[k], index, text)
    log = tmp_path / "odd.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    nmea = read_nmea([log])
    (repair,) = nmea.repairs
    assert (repair.line, repair.field, repair.action) == (k + 1, field, "bad field")
    assert detail in repair.detail
    assert k + 1 not in set(nmea.gnss["nmea_line"]) | set(nmea.velocity["nmea_line"])


def test_a_two_digit_zda_year_is_a_repair(tmp_path: Path) -> None:
    """ZDA's year has four digits; ``24`` is not read as the year 24 (up to 0.4.4 it was, and
    every time was 2000 years early, without a word)."""
    gga = [line for line in _good_epochs(3) if line[3:6] == "GGA"]
    zda = sentence("GPZDA,235940.00,10,03,24,00,00")
    log = tmp_path / "zda.nmea"
    log.write_text("\n".join([zda, *gga]) + "\n", encoding="ascii")
    with pytest.raises(NmeaError, match="no date"):
        read_nmea([log])
    nmea = read_nmea([log], date=dt.date(2024, 3, 10))
    assert [(r.line, r.field, r.action) for r in nmea.repairs] == [(1, "year", "bad field")]
    assert nmea.gnss["utc_s"].iloc[0] == pytest.approx(T0.timestamp() + 10.0)


def test_a_date_that_moves_the_day_is_in_the_repair_log(tmp_path: Path) -> None:
    """A 1-Hz stream whose RMC date jumps two days while its times of day run on: the
    re-anchored day is kept (a log with a gap of days reads right) and now logged (up to
    0.4.4: a 2-day jump in the times, silently)."""
    lines = _good_epochs(5)
    for k in (8, 12, 16):  # the RMCs of the third epoch on
        lines[k] = _with_field(lines[k], 9, "120324")
    log = tmp_path / "date.nmea"
    log.write_text("\n".join(lines) + "\n", encoding="ascii")
    nmea = read_nmea([log])
    moved = [r for r in nmea.repairs if r.action == "date re-anchored"]
    assert [(r.line, r.field) for r in moved] == [(9, "(date)")]
    assert "later times move +2 day(s)" in moved[0].detail
    assert np.diff(nmea.gnss["utc_s"]).round(6).tolist() == [1.0, 172801.0, 1.0, 1.0]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--gnss-name", "g", "--heading-name", "g_velocity"], "--heading-name 'g_velocity'"),
        (["--gnss-name", "../evil"], "--gnss-name: sensor name '../evil'"),
        (["--heading-name", "a/b"], "--heading-name: sensor name 'a/b'"),
        (["--gnss-name", ""], "--gnss-name: sensor name ''"),
        (["--gnss-name", "truth"], "--gnss-name: sensor name 'truth' is reserved"),
        (["--lever-arm-m", "nan,0,0"], "[sensors.gnss]: lever_arm_m[0]: Input should be a finite"),
    ],
)
def test_names_and_options_are_checked_before_anything_is_written(
    tmp_path: Path, args: list[str], message: str
) -> None:
    log = tmp_path / "log.nmea"
    log.write_text("\n".join(_good_epochs(3)) + "\n", encoding="ascii")
    work = tmp_path / "work"
    work.mkdir()
    result = runner.invoke(app, ["import", "nmea", str(log), "--out", str(work / "o"), *args])
    assert result.exit_code == 2, result.output
    assert message in " ".join(result.output.split()), result.output
    assert "Traceback" not in result.output
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["log.nmea", "work"]


def test_day_rolls_over_without_rmc(tmp_path: Path) -> None:
    log = tmp_path / "gga.nmea"
    log.write_text(
        "\n".join(line for line in _good_epochs(40) if line[3:6] == "GGA") + "\n",
        encoding="ascii",
    )
    nmea = read_nmea([log], date=dt.date(2024, 3, 10))
    expected = T0.timestamp() + 10.0 + np.arange(40)
    np.testing.assert_allclose(nmea.gnss["utc_s"], expected, atol=1e-6)
    assert nmea.rollovers == 1 and nmea.date_source == "--date"


@pytest.mark.parametrize(
    ("content", "args", "message"),
    [
        (b"\x00\x01binary\xff\n$GPGGA,1,2\n", [], "no usable NMEA sentence"),
        ("GGA-only", [], "no date"),
        ("ok", ["--date", "2020-01-01"], "--date 2020-01-01 disagrees"),
        ("ok", ["--mission", "{mission}"], "--t0-utc is required"),
        ("ok", ["--mission", "{mission}", "--t0-utc", "2030-01-01T00:00:00"], "no NMEA reading"),
        ("ok", ["--sigma-m", "1,2"], "--sigma-m"),
        ("ok", ["--min-interval-s", "-1"], "--min-interval-s -1.0: must be finite and >= 0"),
        ("ok", ["--t0-utc", "yesterday"], "--t0-utc"),
        ("ok", ["--gnss-name", "dvl", "--mission", "{mission}", "--t0-utc", "2024-03-10"],
         "dvl sensor, not gnss"),
    ],
)  # fmt: skip
def test_refused_input_exits_2(
    tmp_path: Path, original: Path, content: str | bytes, args: list[str], message: str
) -> None:
    log = tmp_path / "log.nmea"
    good = _good_epochs(3)
    if content == "GGA-only":
        content = "\n".join(line for line in good if line[3:6] == "GGA")
    elif content == "ok":
        content = "\n".join(good)
    log.write_bytes(content if isinstance(content, bytes) else content.encode())
    args = [a.replace("{mission}", str(original)) for a in args]
    result = runner.invoke(app, ["import", "nmea", str(log), "--out", str(tmp_path / "o"), *args])
    assert result.exit_code == 2, result.output
    assert message in " ".join(result.output.split()), result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "o").exists()


# --- fuzz ----------------------------------------------------------------------------------------

CLEAN = _good_epochs(8)
CLEAN_LOGS = {
    "HDT": CLEAN,
    "HDT+THS": [x for line in CLEAN for x in ([line, sentence(f"HETHS,{line[7:12]},A")]
                                              if line[3:6] == "HDT" else [line])],
    "HDG": [sentence(f"HCHDG,{line[7:12]},0.5,E,2.0,W") if line[3:6] == "HDT" else line
            for line in CLEAN],
}  # fmt: skip
"""Clean logs whose heading is HDT, a gyro's HDT and THS, a compass's HDG."""


def _refield(line: bytes, pos: int, data: bytes) -> bytes:
    """The sentence with field ``pos`` replaced by printable ``data`` (empty: the field
    removed) and its checksum recomputed: a well-framed sentence with a bad field."""
    body = line[1:].partition(b"*")[0].decode("ascii")
    fields = body.split(",")
    k = 1 + pos % max(1, len(fields) - 1)
    text = "".join(chr(32 + b % 95) for b in data).replace("*", "")
    fields[k : k + 1] = [text] if len(data) > 1 else []
    return sentence(",".join(fields)).encode("ascii")


def _corrupt(lines: list[str], edits: list[tuple[int, int, int, bytes]]) -> bytes:
    """Apply (kind, line, position, bytes) edits: overwrite bytes, truncate, insert bytes,
    repeat a line elsewhere (a time out of order), or change a field keeping the checksum
    right."""
    raw = [line.encode("ascii") for line in lines]
    for kind, i, pos, data in edits:
        i %= len(raw)
        p = pos % (len(raw[i]) + 1)
        if kind == 0:
            raw[i] = raw[i][:p] + data + raw[i][p + len(data) :]
        elif kind == 1:
            raw[i] = raw[i][:p]
        elif kind == 2:
            raw[i] = raw[i][:p] + data + raw[i][p:]
        elif kind == 3:
            raw.insert(pos % len(raw), raw[i])
        elif raw[i].startswith(b"$") and raw[i].isascii():
            raw[i] = _refield(raw[i], pos, data)
    return b"\n".join(raw) + b"\n"


EDITS = st.lists(
    st.tuples(
        st.integers(0, 4), st.integers(0, 99), st.integers(0, 99), st.binary(min_size=1, max_size=4)
    ),
    min_size=1,
    max_size=8,
)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@pytest.mark.parametrize("heading", sorted(CLEAN_LOGS))
@given(edits=EDITS)
def test_corrupted_logs_never_traceback_nor_drop_silently(
    tmp_path: Path, heading: str, edits: list
) -> None:
    log = tmp_path / "fuzz.nmea"
    data = _corrupt(CLEAN_LOGS[heading], edits)
    log.write_bytes(data)
    try:
        nmea = read_nmea([log], date=dt.date(2024, 3, 10))
    except NmeaError as exc:
        assert "fuzz.nmea" in str(exc)
        return
    lines = [no for no, raw in enumerate(data.split(b"\n"), start=1) if raw.strip()]
    placed = {r.line for r in nmea.repairs}
    for table in (nmea.gnss, nmea.heading, nmea.velocity):
        placed |= set(table["nmea_line"].tolist())
    # every line is in a table, in the repair log, or counted among the ignored sentence types
    assert len(placed) + sum(nmea.ignored.values()) == len(lines)
    assert placed <= set(lines)
