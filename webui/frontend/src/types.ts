// The runtime's models the UI uses, by their names in its OpenAPI document (generated from
// the services' own models: see api.ts). Nothing here is written by hand but the narrowing
// of a robot's details.

import type { Schemas } from "./api";

export type DetectedDevice = Schemas["DetectedDevice"];
export type DeviceMark = DetectedDevice["mark"];
export type AddedDevice = Schemas["AddedDevice"];
export type ConnectionStatus = AddedDevice["status"];
export type AddressClaim = Schemas["AddressClaim"];
export type DeviceDetails = Schemas["DeviceDetails"];
export type Pose = Schemas["Pose"];
export type RobotFlags = Schemas["RobotFlags"];
export type CommandMode = Schemas["CommandMode"];
export type OperationalMode = Schemas["OperationalMode"];
export type TrajectoryState = Schemas["TrajectoryState"];
export type TrajectoryStatus = Schemas["TrajectoryStatus"];
export type RobotState = Schemas["RobotState"];
export type InputState = Schemas["InputState"];
export type JointLimits = Schemas["JointLimits"];
export type Payload = Schemas["Payload"];
export type RobotInfo = Schemas["RobotInfo"];

/** A device's details whose kind is a robot: its driver's info is the robot kind's
 * (DeviceDetails has any kind's). */
export type RobotDetails = Omit<DeviceDetails, "info"> & {
  info: { identity: Record<string, string>; info: RobotInfo } | null;
};
