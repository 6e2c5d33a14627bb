"""aerosurvey: UAV photogrammetric survey missions from plan to QA."""

__version__ = "0.1.0"
