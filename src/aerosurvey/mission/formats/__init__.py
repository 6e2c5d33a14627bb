"""Mission file formats. A light module: the command line lists the choices below without loading a writer."""

#: How mission.plan holds the photo passes (`aerosurvey plan --qgc`): each pass as a QGroundControl
#: Survey item the pilot can edit, or every waypoint as a plain item (the first is the default).
QGC_LAYOUTS = ("survey", "items")

#: Which template each DJI .kmz's template.kml holds (`aerosurvey plan --dji`): a mapping template
#: (mapping2d, mappingStrip) where one expresses the flight, else the waypoint template; or always
#: the waypoint template. waylines.wpml is the same either way (the first is the default).
DJI_TEMPLATES = ("mapping", "waypoint")
