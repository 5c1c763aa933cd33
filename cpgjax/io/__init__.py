"""Files: the `.wl` description (:mod:`cpgjax.io.wl`), `.ctl` controllers, thesis logs, HDF5 results.

Every reader reports bad input as ``path:line: what is wrong`` (:class:`cpgjax.errors.DescriptionError`)
or names the results file (:class:`cpgjax.errors.ResultsError`).
"""
