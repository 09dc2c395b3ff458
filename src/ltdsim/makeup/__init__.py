"""Make-up studies (``ltdsim makeup``): a population of random train make-ups of loaded
and empty wagons drawn under composition rules from one base scenario (study: the
study file's validated keys; draws: the seeded population and each make-up's scenario
overrides), run through standard manoeuvres (manoeuvres) on the sweep's executor, one
sweep case per make-up and manoeuvre, local or on Dask and resumable as a sweep is
(run); the population's largest longitudinal compressive and tensile forces, their
distribution, exceedance probabilities with exact confidence intervals and what the
worst make-ups share (results), and its page of figures and CSV tables (report).

This layer sits above ``study``: its page is built with the study report's page
helpers (``ltdsim.study.report.html``). May import the base modules, ``physics``,
``scenario``, ``engine``, ``results``, ``analysis``, ``viz``, ``sweep`` and ``study``;
only ``cli`` imports it.
"""
