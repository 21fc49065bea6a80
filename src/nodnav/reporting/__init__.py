"""Reports: ``report.md`` written from a results database, and the paper's whole evaluation run
into one (:mod:`nodnav.reporting.reproduce`), above the studies of :mod:`nodnav.experiments`."""
