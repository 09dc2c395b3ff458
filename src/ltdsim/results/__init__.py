"""A run's result and what is read from it: :func:`simulate` turns a scenario into its
labelled ``xarray.Dataset`` (simulate), results are saved and loaded as netCDF-4 with
atomic writes (io), summarised (summary: coupler peaks, gear travel, stops, the energy
balance), checked against the couplers' strengths (strength) and fatigue curves
(fatigue: rainflow counts and Miner damage) and, for curving safety, post-processed on
the track in the plane (curving).

May import the base modules, ``physics``, ``scenario`` and ``engine``.
"""
