"""ROS 2 bags: ``adaptnav import rosbag`` (a bag → a mission folder) and ``adaptnav export
rosbag`` (a run's solution → a bag of nav_msgs/msg/Odometry); docs/rosbag.md."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from adaptnav.cli._app import Force, Quiet, Stages, app, console, fail, output
from adaptnav.cli.importers import import_app

export_app = typer.Typer(
    help="Export runs to other formats (docs/rosbag.md).",
    no_args_is_help=True,
)
app.add_typer(export_app, name="export")


def _topic(role: str, types: str) -> Any:
    return typer.Option(f"--{role}", help=f"topic of the {role}: {types}")


@import_app.command("rosbag")
def import_rosbag(
    bag: Annotated[Path, typer.Argument(help="rosbag2 folder (sqlite3 or MCAP) or its file")],
    out: Annotated[Path, typer.Option("--out", "-o", help="mission folder to write")],
    imu: Annotated[
        str | None, _topic("imu", "sensor_msgs/msg/Imu (default: the bag's one)")
    ] = None,
    dvl: Annotated[
        str | None, _topic("dvl", "geometry_msgs/msg/TwistWithCovarianceStamped")
    ] = None,
    depth: Annotated[
        str | None,
        _topic("depth", "sensor_msgs/msg/FluidPressure or PoseWithCovarianceStamped (-z)"),
    ] = None,
    gnss: Annotated[str | None, _topic("gnss", "sensor_msgs/msg/NavSatFix")] = None,
    inclinometer: Annotated[
        str | None, _topic("inclinometer", "Imu orientation or QuaternionStamped (roll, pitch)")
    ] = None,
    heading: Annotated[
        str | None, _topic("heading", "Imu orientation or QuaternionStamped (yaw)")
    ] = None,
    config: Annotated[
        Path | None,
        typer.Option(
            help="mission.toml giving the IMU noise, sensors (matched by kind), initial state "
            "and filter settings"
        ),
    ] = None,
    water_density: Annotated[float, typer.Option(help="kg/m³, depth from FluidPressure")] = 1025.0,
    atmospheric_pressure: Annotated[
        float, typer.Option(help="Pa, depth from FluidPressure")
    ] = 101325.0,
    imu_sample: Annotated[
        str,
        typer.Option(help="Imu rates: mean (over the interval ending at the stamp) | instant"),
    ] = "mean",
    log_time: Annotated[
        list[str] | None,
        typer.Option(
            "--log-time",
            help="time this topic by the bag's log time, not its header stamps (a driver on "
            "its own clock); repeatable",
        ),
    ] = None,
    stamp_tolerance_s: Annotated[
        float | None,
        typer.Option(
            help="s a header stamp may stray from its topic's clock, and a topic's clock from "
            "the IMU's (default: 10, importers.rosbag.STAMP_TOLERANCE_S; docs/rosbag.md, 'Clocks')"
        ),
    ] = None,
    csv: Annotated[bool, typer.Option("--csv", help="write CSV tables (default Parquet)")] = False,
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """Import a ROS 2 bag (sqlite3 or MCAP) as a mission folder.

    Each topic given takes one role; body FLU and world ENU are turned into adaptnav's FRD and
    NED, mission time is the header stamp minus a whole-second origin. σ, rates, lever arms and
    mountings come from --config (a mission.toml), else σ from the messages' covariances.
    import.json in the mission folder records the topics, frame ids, σ sources and repairs.
    """
    from adaptnav.importers.rosbag import STAMP_TOLERANCE_S, import_bag
    from adaptnav.importers.rosmsg import DepthParameters
    from adaptnav.mission import MissionError

    if imu_sample not in ("mean", "instant"):
        fail(f"--imu-sample: {imu_sample!r} must be mean or instant")
    if not (water_density > 0.0 and atmospheric_pressure >= 0.0):
        fail("--water-density must be > 0 and --atmospheric-pressure >= 0")
    tolerance_s = STAMP_TOLERANCE_S if stamp_tolerance_s is None else stamp_tolerance_s
    if not tolerance_s > 0.0:
        fail(f"--stamp-tolerance-s: {tolerance_s!r} must be > 0")
    topics = {
        "imu": imu,
        "dvl": dvl,
        "depth": depth,
        "gnss": gnss,
        "inclinometer": inclinometer,
        "heading": heading,
    }
    with output(out, force, inputs=[bag]) as tmp, Stages(quiet) as st:
        st.begin(f"reading {bag} and writing the mission")
        try:
            import_bag(
                bag,
                tmp,
                topics={k: v for k, v in topics.items() if v is not None},
                config=config,
                depth=DepthParameters(water_density, atmospheric_pressure),
                imu_sample=imu_sample,  # type: ignore[arg-type]
                fmt="csv" if csv else "parquet",
                log_time=tuple(log_time or ()),
                stamp_tolerance_s=tolerance_s,
            )
        except (MissionError, ValueError, OSError) as exc:  # RosbagError is a MissionError
            fail(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    _report_import(out)


def _report_import(out: Path) -> None:
    """Print the roles of an import.json (topic, type, rows, frame ids, σ source), its
    repairs and notes."""
    info = json.loads((out / "import.json").read_text(encoding="utf-8"))
    table = Table(title=f"ROS 2 bag {Path(info['bag']).name}")
    for col in ("role", "topic", "type", "messages", "rows", "frame_id", "σ / noise from"):
        table.add_column(col)
    for role, r in info["roles"].items():
        source = r.get("sigma_source", r.get("noise_source"))
        table.add_row(
            role,
            r["topic"],
            r["type"].rsplit("/", 1)[-1],
            str(r["messages"]),
            str(r["rows"]),
            ", ".join(r["frame_ids"]),
            source,
        )
    console.print(table)
    for repair in info["repairs"]:
        console.print(
            f"[yellow]repaired:[/] {repair['file']}: {repair['action']} ({repair['detail']})"
        )
    for note in info["notes"]:
        console.print(f"note: {note}")
    console.print(f"mission written to {out} (stamp origin {info['stamp_origin']})")


@export_app.command("rosbag")
def export_rosbag(
    run: Annotated[Path, typer.Argument(help="run folder (adaptnav run --out)")],
    out: Annotated[Path, typer.Option("--out", "-o", help="bag folder to write")],
    storage: Annotated[str, typer.Option(help="sqlite3 | mcap")] = "sqlite3",
    topic: Annotated[str, typer.Option(help="odometry topic")] = "/adaptnav/odometry",
    frame_id: Annotated[str, typer.Option(help="world frame: local ENU at the datum")] = "map",
    child_frame_id: Annotated[str, typer.Option(help="body frame (FLU)")] = "base_link",
    stamp_origin_ns: Annotated[
        int | None,
        typer.Option(
            help="stamp of mission time 0 (ns since 1970, UTC) (default: the mission's, from "
            "its bag, NMEA log or RTKLIB drive; else 0, with a warning)"
        ),
    ] = None,
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """Write a run's solution as a ROS 2 bag of nav_msgs/msg/Odometry.

    The pose is in a local ENU frame at the first solution position (the datum, also written
    as one NavSatFix on /adaptnav/datum), the twist in the body's FLU axes, the covariances
    from the run's σ and covariance columns; docs/rosbag.md.
    """
    from adaptnav.api.results import RunFolderError
    from adaptnav.importers.rosbag import ExportTopics, export_run

    if storage not in ("sqlite3", "mcap"):
        fail(f"--storage: {storage!r} must be sqlite3 or mcap")
    names = ExportTopics(odometry=topic, frame_id=frame_id, child_frame_id=child_frame_id)
    with output(out, force, inputs=[run]) as tmp, Stages(quiet) as st:
        st.begin(f"writing {out}")
        try:
            info = export_run(
                run,
                tmp,
                name=out.name,
                storage=storage,  # type: ignore[arg-type]
                names=names,
                stamp_origin_ns=stamp_origin_ns,
            )
        except (RunFolderError, ValueError, OSError) as exc:
            fail(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    lat, lon, h = info["datum_deg_m"]
    console.print(
        f"{info['messages']} Odometry messages on {topic} ({frame_id} → {child_frame_id}), "
        f"datum {lat:.7f}°, {lon:.7f}°, {h:.2f} m, stamp origin {info['stamp_origin_ns']} ns; "
        f"{storage} bag written to {out}"
    )
