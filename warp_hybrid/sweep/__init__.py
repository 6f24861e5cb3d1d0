"""Speed against error: a sweep of rendering methods per scene against a converged
reference (``warp-hybrid bench``): the configurations (``configs``), their timed renders
and errors (``measure``), and the tables and plots (``report``).  Import the submodules
(the command line reads ``configs`` without paying for the rest)."""
