// Domain types -> the ROS 2 view's messages (cpgmatch_msgs::msg::dds_::*_, generated from the .msg files of
// idl/ros2/cpgmatch_msgs). One way only: the view is read-only, nothing comes back from ROS 2.
// Enums become the uint8 constants of the .msg files (rosidl has no enums); units stay SI.
#pragma once

#include "cpgmatch/domain/study_state.hpp"
#include "cpgmatch/domain/worker_announcement.hpp"
#include "cpgmatch_ros2_msgs.h"

namespace cpgmatch::dds {

namespace ros = cpgmatch_msgs::msg::dds_;

ros::StudyState_ to_ros(const domain::StudyState& state);
ros::TrialRecord_ to_ros(const domain::TrialRecord& record);
// `alive` false: the worker left or fell silent (this is its last announcement).
ros::Worker_ to_ros(const domain::WorkerAnnouncement& announcement, bool alive);

std::uint8_t ros_status(domain::StudyStatus status);   // StudyState_Constants::STATUS_*
std::uint8_t ros_outcome(domain::Outcome outcome);     // TrialRecord_Constants::OUTCOME_*

}  // namespace cpgmatch::dds
