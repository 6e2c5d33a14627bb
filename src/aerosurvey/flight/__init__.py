"""Flight records brought back: logs and photo folders against the plan they flew.

A light package init: the command line shows the defaults below without loading a module of the package.
"""

#: gaps smaller than this (m²) are not re-flown unless `refly --min-gap-m2` says otherwise (the page uses it too)
MIN_GAP_DEFAULT_M2 = 25.0
#: a day of flights' report (`log ingest` with several records: flight/day.py), in the day's folder
DAY_FILE = "day_report.json"
