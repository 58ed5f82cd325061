"""Foundations that import nothing else from adaptnav: the WGS84 Earth model
(:mod:`~adaptnav.core.earth`), rotations and quaternions (:mod:`~adaptnav.core.attitude`) and
human units at the edges (:mod:`~adaptnav.core.units`). docs/architecture.md has the layers."""
