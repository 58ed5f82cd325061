"""Command line: the only place that knows files and human units (degrees, hours).

One module per group of commands, each registering on the one :data:`app`:
:mod:`~adaptnav.cli.core` (demo, run, evaluate, simulate, version);
:mod:`~adaptnav.cli.compare` (compare, report);
:mod:`~adaptnav.cli.calibrate` (fit-dvl);
:mod:`~adaptnav.cli.importers` (import akit, import rtklib);
:mod:`~adaptnav.cli.rosbag` (import rosbag, export rosbag);
:mod:`~adaptnav.cli.nmea` (import nmea);
:mod:`~adaptnav.cli.track` (export track);
:mod:`~adaptnav.cli.sweep` (sweep q, sweep process-noise, sweep seeds).
"""

from adaptnav.cli import calibrate as calibrate
from adaptnav.cli import compare as compare
from adaptnav.cli import core as core
from adaptnav.cli import importers as importers
from adaptnav.cli import nmea as nmea
from adaptnav.cli import rosbag as rosbag
from adaptnav.cli import sweep as sweep
from adaptnav.cli import track as track
from adaptnav.cli._app import app

__all__ = ["app"]
