"""The MAVLink command and frame numbers aerosurvey writes (MAVLink common.xml).

Kept here as plain integers so that pure planning code does not import pymavlink.
"""

# MAV_CMD
NAV_WAYPOINT = 16
NAV_RETURN_TO_LAUNCH = 20
NAV_LAND = 21
NAV_TAKEOFF = 22
NAV_VTOL_TAKEOFF = 84
NAV_VTOL_LAND = 85
CONDITION_YAW = 115
DO_CHANGE_SPEED = 178
DO_LAND_START = 189
DO_SET_ROI_LOCATION = 195
DO_SET_ROI_WPNEXT_OFFSET = 196
DO_SET_ROI_NONE = 197
DO_SET_CAM_TRIGG_DIST = 206
DO_SET_CAM_TRIGG_INTERVAL = 214
NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
NAV_FENCE_POLYGON_VERTEX_EXCLUSION = 5002

# MAV_FRAME
FRAME_GLOBAL = 0
FRAME_GLOBAL_RELATIVE_ALT = 3
FRAME_MISSION = 2
FRAME_GLOBAL_TERRAIN_ALT = 10

# MAV_AUTOPILOT (QGroundControl's firmwareType) and MAV_TYPE (vehicleType)
AUTOPILOT_GENERIC = 0
AUTOPILOT_ARDUPILOTMEGA = 3
AUTOPILOT_PX4 = 12
TYPE_FIXED_WING = 1
TYPE_QUADROTOR = 2

# camera and gimbal commands (hover-and-shoot, gimbal pitch)
DO_DIGICAM_CONTROL = 203
DO_MOUNT_CONTROL = 205
DO_GIMBAL_MANAGER_PITCHYAW = 1000
IMAGE_START_CAPTURE = 2000
MOUNT_MODE_MAVLINK_TARGETING = 2  # MAV_MOUNT_MODE
GIMBAL_MANAGER_FLAGS_ROLL_LOCK = 4  # GIMBAL_MANAGER_FLAGS
GIMBAL_MANAGER_FLAGS_PITCH_LOCK = 8
GIMBAL_MANAGER_FLAGS_YAW_LOCK = 16  # the yaw an earth-frame bearing (else relative to the vehicle)
NAV_RALLY_POINT = 5100  # one rally point (MAV_MISSION_TYPE_RALLY)

# What PX4 takes: its MavlinkMissionManager (src/modules/mavlink/mavlink_mission.cpp,
# parse_mavlink_mission_item) takes these commands with a position (frames 0, 3, 5, 6) and without one
# (frame 2, MAV_FRAME_MISSION) and answers anything else MAV_MISSION_UNSUPPORTED (`link.upload.px4_refusal`)
PX4_POSITION_COMMANDS = frozenset({16, 17, 19, 21, 22, 31, 80, 84, 85, 195, 201, 212, 400, 4501, 5000, 5001, 5002, 5003, 5004,
                                   NAV_RALLY_POINT})
PX4_MISSION_FRAME_COMMANDS = frozenset({20, 80, 93, 112, 114, 177, 178, 179, 187, 189, 197, 200, 201, 203, 204, 205, 206, 211,
                                        212, 213, 214, 260, 400, 530, 532, 534, 1000, 1001, 2000, 2001, 2003, 2500, 2501, 3000,
                                        42600})
