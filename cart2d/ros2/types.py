"""ROS 2's message types as DDS sees them, declared once: each a final (plain CDR) struct under
the name rmw_cyclonedds gives it, `<package>::msg::dds_::<Message>_` (services: `srv`, actions:
`action`), with ROS's field names and sizes (ros2/common_interfaces, ros2/rcl_interfaces,
ros2/rmw_dds_common, nav2_msgs; Jazzy and Kilted define these alike). tests/ros2/ checks the
bytes of each against rosbags' serializer of the ROS definitions.

A service's request and reply carry rmw_cyclonedds' request header first (the client's writer
id and the request's sequence number, two 64-bit integers), then the ROS fields."""

# No `from __future__ import annotations`: cyclonedds resolves the fields' types at run time.

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Annotated

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import (
    array,
    bounded_str,
    byte,
    float32,
    float64,
    int8,
    int16,
    int32,
    int64,
    sequence,
    uint8,
    uint16,
    uint32,
    uint64,
)

# -- builtin_interfaces, std_msgs, unique_identifier_msgs -----------------------------------------


@final
@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@final
@dataclass
class Duration(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@final
@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@final
@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str = ""


@final
@dataclass
class UUID(IdlStruct, typename="unique_identifier_msgs::msg::dds_::UUID_"):
    uuid: Annotated[Sequence[uint8], array(uint8, 16)] = field(default_factory=lambda: bytes(16))


# -- geometry_msgs ---------------------------------------------------------------------------------


@final
@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@final
@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@final
@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@final
@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@final
@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


def _covariance() -> list[float]:
    return [0.0] * 36


@final
@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose = field(default_factory=Pose)
    covariance: Annotated[Sequence[float64], array(float64, 36)] = field(default_factory=_covariance)


@final
@dataclass
class PoseWithCovarianceStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"):
    header: Header = field(default_factory=Header)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@final
@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@final
@dataclass
class TwistStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TwistStamped_"):
    header: Header = field(default_factory=Header)
    twist: Twist = field(default_factory=Twist)


@final
@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist = field(default_factory=Twist)
    covariance: Annotated[Sequence[float64], array(float64, 36)] = field(default_factory=_covariance)


@final
@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@final
@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@final
@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: Annotated[Sequence[TransformStamped], sequence(TransformStamped)] = field(
        default_factory=list
    )


# -- nav_msgs -------------------------------------------------------------------------------------


@final
@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@final
@dataclass
class MapMetaData(IdlStruct, typename="nav_msgs::msg::dds_::MapMetaData_"):
    map_load_time: Time = field(default_factory=Time)
    resolution: float32 = 0.0
    width: uint32 = 0
    height: uint32 = 0
    origin: Pose = field(default_factory=Pose)


@final
@dataclass
class OccupancyGrid(IdlStruct, typename="nav_msgs::msg::dds_::OccupancyGrid_"):
    header: Header = field(default_factory=Header)
    info: MapMetaData = field(default_factory=MapMetaData)
    data: Annotated[Sequence[int8], sequence(int8)] = field(default_factory=list)


@final
@dataclass
class Path(IdlStruct, typename="nav_msgs::msg::dds_::Path_"):
    header: Header = field(default_factory=Header)
    poses: Annotated[Sequence[PoseStamped], sequence(PoseStamped)] = field(default_factory=list)


# -- sensor_msgs ----------------------------------------------------------------------------------


@final
@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header = field(default_factory=Header)
    name: Annotated[Sequence[str], sequence(str)] = field(default_factory=list)
    position: Annotated[Sequence[float64], sequence(float64)] = field(default_factory=list)
    velocity: Annotated[Sequence[float64], sequence(float64)] = field(default_factory=list)
    effort: Annotated[Sequence[float64], sequence(float64)] = field(default_factory=list)


@final
@dataclass
class LaserScan(IdlStruct, typename="sensor_msgs::msg::dds_::LaserScan_"):
    header: Header = field(default_factory=Header)
    angle_min: float32 = 0.0
    angle_max: float32 = 0.0
    angle_increment: float32 = 0.0
    time_increment: float32 = 0.0
    scan_time: float32 = 0.0
    range_min: float32 = 0.0
    range_max: float32 = 0.0
    ranges: Annotated[Sequence[float32], sequence(float32)] = field(default_factory=list)
    intensities: Annotated[Sequence[float32], sequence(float32)] = field(default_factory=list)


@final
@dataclass
class CompressedImage(IdlStruct, typename="sensor_msgs::msg::dds_::CompressedImage_"):
    header: Header = field(default_factory=Header)
    format: str = ""
    data: Annotated[Sequence[uint8], sequence(uint8)] = field(default_factory=list)


@final
@dataclass
class RegionOfInterest(IdlStruct, typename="sensor_msgs::msg::dds_::RegionOfInterest_"):
    x_offset: uint32 = 0
    y_offset: uint32 = 0
    height: uint32 = 0
    width: uint32 = 0
    do_rectify: bool = False


@final
@dataclass
class CameraInfo(IdlStruct, typename="sensor_msgs::msg::dds_::CameraInfo_"):
    header: Header = field(default_factory=Header)
    height: uint32 = 0
    width: uint32 = 0
    distortion_model: str = ""
    d: Annotated[Sequence[float64], sequence(float64)] = field(default_factory=list)
    k: Annotated[Sequence[float64], array(float64, 9)] = field(default_factory=lambda: [0.0] * 9)
    r: Annotated[Sequence[float64], array(float64, 9)] = field(default_factory=lambda: [0.0] * 9)
    p: Annotated[Sequence[float64], array(float64, 12)] = field(default_factory=lambda: [0.0] * 12)
    binning_x: uint32 = 0
    binning_y: uint32 = 0
    roi: RegionOfInterest = field(default_factory=RegionOfInterest)


# -- diagnostic_msgs, rcl_interfaces ---------------------------------------------------------------


@final
@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str = ""
    value: str = ""


@final
@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: byte = 0  # OK 0, WARN 1, ERROR 2, STALE 3 (ROS's byte: an IDL octet, not a uint8)
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: Annotated[Sequence[KeyValue], sequence(KeyValue)] = field(default_factory=list)


@final
@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header = field(default_factory=Header)
    status: Annotated[Sequence[DiagnosticStatus], sequence(DiagnosticStatus)] = field(default_factory=list)


@final
@dataclass
class Log(IdlStruct, typename="rcl_interfaces::msg::dds_::Log_"):
    stamp: Time = field(default_factory=Time)
    level: uint8 = 0  # DEBUG 10, INFO 20, WARN 30, ERROR 40, FATAL 50
    name: str = ""
    msg: str = ""
    file: str = ""
    function: str = ""
    line: uint32 = 0


# -- rmw_dds_common: the node in `ros2 node list` --------------------------------------------------


@final
@dataclass
class Gid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    data: Annotated[Sequence[uint8], array(uint8, 16)] = field(default_factory=lambda: bytes(16))


@final
@dataclass
class NodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
    node_namespace: Annotated[str, bounded_str(256)] = ""  # string<=256, as rmw_dds_common has it
    node_name: Annotated[str, bounded_str(256)] = ""
    reader_gid_seq: Annotated[Sequence[Gid], sequence(Gid)] = field(default_factory=list)
    writer_gid_seq: Annotated[Sequence[Gid], sequence(Gid)] = field(default_factory=list)


@final
@dataclass
class ParticipantEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"):
    gid: Gid = field(default_factory=Gid)
    node_entities_info_seq: Annotated[Sequence[NodeEntitiesInfo], sequence(NodeEntitiesInfo)] = field(
        default_factory=list
    )


# -- std_srvs/Trigger, with rmw_cyclonedds' request header ------------------------------------------


@final
@dataclass
class TriggerRequest(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    guid: uint64 = 0  # rmw_cyclonedds' header: the client's request writer
    seq: int64 = 0  # and the request's number, echoed in the reply
    structure_needs_at_least_one_member: uint8 = 0  # an empty ROS request, as rosidl's IDL has it


@final
@dataclass
class TriggerResponse(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    guid: uint64 = 0
    seq: int64 = 0
    success: bool = False
    message: str = ""


# -- action_msgs and nav2_msgs/action/NavigateToPose ------------------------------------------------


@final
@dataclass
class GoalInfo(IdlStruct, typename="action_msgs::msg::dds_::GoalInfo_"):
    goal_id: UUID = field(default_factory=UUID)
    stamp: Time = field(default_factory=Time)


@final
@dataclass
class GoalStatus(IdlStruct, typename="action_msgs::msg::dds_::GoalStatus_"):
    goal_info: GoalInfo = field(default_factory=GoalInfo)
    status: int8 = 0  # UNKNOWN 0, ACCEPTED 1, EXECUTING 2, CANCELING 3, SUCCEEDED 4, CANCELED 5, ABORTED 6


@final
@dataclass
class GoalStatusArray(IdlStruct, typename="action_msgs::msg::dds_::GoalStatusArray_"):
    status_list: Annotated[Sequence[GoalStatus], sequence(GoalStatus)] = field(default_factory=list)


@final
@dataclass
class CancelGoalRequest(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Request_"):
    guid: uint64 = 0
    seq: int64 = 0
    goal_info: GoalInfo = field(default_factory=GoalInfo)


@final
@dataclass
class CancelGoalResponse(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Response_"):
    guid: uint64 = 0
    seq: int64 = 0
    return_code: int8 = 0  # NONE 0, REJECTED 1, UNKNOWN_GOAL_ID 2, GOAL_TERMINATED 3
    goals_canceling: Annotated[Sequence[GoalInfo], sequence(GoalInfo)] = field(default_factory=list)


@final
@dataclass
class NavigateToPoseGoal(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_Goal_"):
    pose: PoseStamped = field(default_factory=PoseStamped)
    behavior_tree: str = ""


@final
@dataclass
class NavigateToPoseResult(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_Result_"):
    error_code: uint16 = 0  # NONE 0, ... (nav2's codes: 9xxx for bt_navigator's own)
    error_msg: str = ""


@final
@dataclass
class NavigateToPoseFeedback(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_Feedback_"):
    current_pose: PoseStamped = field(default_factory=PoseStamped)
    navigation_time: Duration = field(default_factory=Duration)
    estimated_time_remaining: Duration = field(default_factory=Duration)
    number_of_recoveries: int16 = 0
    distance_remaining: float32 = 0.0


@final
@dataclass
class NavigateToPoseSendGoalRequest(
    IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_SendGoal_Request_"
):
    guid: uint64 = 0
    seq: int64 = 0
    goal_id: UUID = field(default_factory=UUID)
    goal: NavigateToPoseGoal = field(default_factory=NavigateToPoseGoal)


@final
@dataclass
class NavigateToPoseSendGoalResponse(
    IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_SendGoal_Response_"
):
    guid: uint64 = 0
    seq: int64 = 0
    accepted: bool = False
    stamp: Time = field(default_factory=Time)


@final
@dataclass
class NavigateToPoseGetResultRequest(
    IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_GetResult_Request_"
):
    guid: uint64 = 0
    seq: int64 = 0
    goal_id: UUID = field(default_factory=UUID)


@final
@dataclass
class NavigateToPoseGetResultResponse(
    IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_GetResult_Response_"
):
    guid: uint64 = 0
    seq: int64 = 0
    status: int8 = 0
    result: NavigateToPoseResult = field(default_factory=NavigateToPoseResult)


@final
@dataclass
class NavigateToPoseFeedbackMessage(
    IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_FeedbackMessage_"
):
    goal_id: UUID = field(default_factory=UUID)
    feedback: NavigateToPoseFeedback = field(default_factory=NavigateToPoseFeedback)
