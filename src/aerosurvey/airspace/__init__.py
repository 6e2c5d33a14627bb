"""Official UAS geographical zones (ED-269, ED-318): read (read.py), as plain data (model.py),
kept clear by the route where they forbid the whole flight's heights (route.py), and every
leg of every flight checked against them in four dimensions (legs.py, check.py)."""
