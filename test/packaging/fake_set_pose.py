#!/usr/bin/env python3
"""A stand-in for robot_localization's set_pose service, for the README test.

It serves the type robot_localization/SetPose (not relocalizer/SetPose) with the md5sum of
the definition the node compiles, as a real robot_localization node does, and writes each pose
it gets as YAML to the file named by its second argument.
    fake_set_pose.py SERVICE OUTPUT
"""
import sys

import rospy
from relocalizer.srv import SetPose, SetPoseRequest, SetPoseResponse


class Request(SetPoseRequest):
    _type = "robot_localization/SetPoseRequest"


class Response(SetPoseResponse):
    _type = "robot_localization/SetPoseResponse"


class RobotLocalizationSetPose:
    _type = "robot_localization/SetPose"
    _md5sum = SetPose._md5sum
    _request_class = Request
    _response_class = Response


def main():
    service, output = sys.argv[1], sys.argv[2]
    rospy.init_node("fake_robot_localization")

    def handle(request):
        with open(output, "a") as f:
            f.write(str(request.pose) + "\n---\n")
        return Response()

    rospy.Service(service, RobotLocalizationSetPose, handle)
    rospy.spin()


if __name__ == "__main__":
    main()
