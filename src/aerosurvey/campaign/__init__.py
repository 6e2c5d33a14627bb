"""Campaigns: many blocks planned, flown and accepted as one record (docs/campaign.md).

blocks.py   the blocks file (GeoPackage or GeoJSON of polygons, attributes overriding spec keys): its one reader
job.py      one block's job (picklable inputs and the key derived from them) and `plan_block`, the function every
            executor runs: the block planned and its outputs written into a temporary folder renamed to the key
run.py      the driver: the blocks not yet done handed to an executor (a local process pool or Dask distributed),
            results streamed back, progress, the register written at the end
register.py register.gpkg: the blocks layer (geometry, status, plan summary) and the events layer; its one writer and reader
split.py    an area cut into blocks along straight cuts aligned with the flight lines, overlapping at each cut
"""
