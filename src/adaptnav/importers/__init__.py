"""Applications that turn other formats into mission folders: the Snapir AUV (A-KIT) segments
(:mod:`~adaptnav.importers.akit`), the RTKLIB car drive (:mod:`~adaptnav.importers.rtklib`),
ROS 2 bags (:mod:`~adaptnav.importers.rosbag`, which also exports runs as Odometry) and NMEA
0183 logs (:mod:`~adaptnav.importers.nmea`)."""
