"""adaptnav: asynchronous multirate multi-sensor inertial navigation.

Strapdown INS in NED fused with asynchronous aiding sensors (DVL, depth, inclinometer,
heading, GNSS) by error-state Kalman filters whose measurement noise is fixed (MESKF),
matched to the innovations (MAESKF) or estimated by variational Bayes (VB-MAESKF),
after Davari & Gholami, Ocean Engineering 174 (2019).

Conventions (the full contract is ``docs/conventions.md``):

* Frames: ``n`` = local-level NED, ``b`` = body FRD, ``e`` = ECEF (WGS84).
  ``vec_a`` is resolved in frame a; ``C_ab``/``q_ab`` rotates frame-b vectors into frame a.
* Units: SI and radians inside; human units only at I/O edges (``adaptnav.core.units``).
* Quaternions are ``[w, x, y, z]``, Hamilton product; Euler angles are ZYX (yaw, pitch, roll).
* Nominal state: ``[lat, lon, h, v_NED, q_nb, b_a, b_g]`` (16 numbers).
* Error state: ``dx = [dr_NED, dv_NED, phi, db_a, db_g]`` (15), **truth minus estimate**;
  attitude ``C_nb_true = Exp(phi) C_nb_hat``.
* Measurement residual ``y = z - h(x_hat)``, ``H = d h(x_hat (+) dx) / d dx``.
"""

__version__ = "0.4.13"
