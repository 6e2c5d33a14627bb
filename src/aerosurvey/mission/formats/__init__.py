"""Mission file formats. A light module: the command line lists the choices below without loading a writer."""

#: How mission.plan holds the photo passes (`aerosurvey plan --qgc`): each pass as a QGroundControl
#: Survey or Corridor Scan item the pilot can edit, laid for QGroundControl 5.1 and later ("survey")
#: or for 4.x-5.0 ("survey-5.0": they project the item on another plane), or every waypoint as a
#: plain item (the first is the default).
QGC_LAYOUTS = ("survey", "survey-5.0", "items")

#: Which template each DJI .kmz's template.kml holds (`aerosurvey plan --dji`): a mapping template
#: (mapping2d, mappingStrip) where one expresses the flight, else the waypoint template; or always
#: the waypoint template. waylines.wpml is the same either way (the first is the default).
DJI_TEMPLATES = ("mapping", "waypoint")
