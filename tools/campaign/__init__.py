"""``sitl campaign``: Monte-Carlo dispersion campaigns of headless SITL flights.

A campaign file (TOML, ``missions/campaigns/``) names a mission, the run options and
parameters to disperse with a distribution each, timed fault events with dispersed
times and magnitudes, and named pass/fail criteria over the flight summary. Trial ``i``
is a pure function of (file, i): its seed and every dispersed value are drawn from
generators seeded by (campaign seed, i) only, so any trial is replayed from its index
(``sitl campaign show FILE --trial I`` prints the ``sitl run`` command that flies it).

Trials run in-process on Dask distributed workers (a LocalCluster by default, or an
existing cluster by its scheduler address); each finished trial is committed to a DuckDB
file in the campaign folder at once, so an interrupted campaign resumes with the missing
trials only.

Modules: ``spec`` (the file: schema, distributions, checks with line numbers),
``criteria`` (summary flattening, criterion expressions, known summary keys),
``trials`` (resolution of trial i: inputs, seed, command line), ``execute`` (the
worker-side trial and the Dask driver), ``store`` (DuckDB), ``report`` (HTML page),
``export`` (Parquet / CSV), ``cli`` (the subcommands).
"""
