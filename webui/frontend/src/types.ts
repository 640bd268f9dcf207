// Shapes of the runtime's API (see runtime/device_manager/models.py, runtime/interfaces/).

export interface DetectedDevice {
  uuid: string;
  name: string;
  kind: string;
  model: string;
  api: string;
  address: string;
  url: string;
  added_as: string | null;
  last_seen: number;
  also_at: string[]; // other addresses announcing this uuid (an impostor, or a stale record)
  mark: DeviceMark;
  elsewhere: "other_runtime" | "other_key" | null; // why another's
}

// How this runtime sees a device on the network: one of its devices, paired with it (it holds
// the device's key), another's, or none of these (runtime/device_manager/announcements.py).
export type DeviceMark = "added" | "paired" | "elsewhere" | "new";

export type ConnectionStatus = "connecting" | "connected" | "stale" | "disconnected";

// Another address an added device was seen at: announced there while its link was live (not
// followed), or where it was before it moved (followed). `proven`: not followed, though the
// device proved it serves from that address; the move waits for the user (its link was live,
// or its robot was moving or in a fault).
export interface AddressClaim {
  url: string;
  name: string;
  seen: number;
  followed: boolean;
  proven: boolean;
}

export interface AddedDevice {
  local_name: string;
  uuid: string;
  kind: string;
  model: string;
  name: string;
  url: string;
  status: ConnectionStatus;
  last_error: string;
  connected_since: number | null;
  detected: boolean;
  controlled_by: string | null;
  control_expires: number | null;
  link: number;
  state_age: number | null;
  address_claim: AddressClaim | null;
}

export interface Pose {
  position: [number, number, number];
  orientation: [number, number, number, number];
}

export interface RobotFlags {
  enabled: boolean;
  ready: boolean;
  error: boolean;
  estop: boolean;
  protective_stop: boolean;
  reduced_speed: boolean;
  homed: boolean;
  communication_failure: boolean;
  trajectory_running: boolean;
}

export type CommandMode =
  | "halt"
  | "jog"
  | "trajectory"
  | "position_command"
  | "velocity_command"
  | "freedrive";

export type OperationalMode =
  | "manual_reduced_speed"
  | "manual_full_speed"
  | "auto"
  | "undefined";

/** "paused": brought to a stop on its path; it resumes where it stopped. */
export type TrajectoryState = "running" | "paused" | "finished" | "aborted" | "failed";

export interface TrajectoryStatus {
  id: string;
  state: TrajectoryState;
  progress: number;
  message: string;
}

// runtime/interfaces/robot.py. Fields with a default there are always sent (a state is the
// whole model as the driver dumps it), so none is optional here.
export interface RobotState {
  seqno: number;
  ts: number;
  command_mode: CommandMode;
  operational_mode: OperationalMode;
  flags: RobotFlags;
  joint_position: number[];
  joint_velocity: number[];
  joint_position_command: number[];
  tcp_pose: Pose;
  speed_ratio: number;
  error_message: string;
  trajectory: TrajectoryStatus | null; // the one under way (running or paused), null: none
  tool_open: boolean | null; // null: no tool, or not known yet
  digital_inputs: boolean[];
  digital_outputs: boolean[];
}

/** A 3D mouse's state (runtime/interfaces/input.py): axes in [-1, 1], x y z rx ry rz. */
export interface InputState {
  seqno: number;
  ts: number;
  axes: number[];
  buttons: number[];
  connected: boolean;
  error: string;
}

export interface JointLimits {
  name: string;
  lower: number;
  upper: number;
  max_velocity: number;
  max_acceleration: number;
  max_jerk: number | null;
}

export interface Payload {
  mass: number; // kg
  center_of_mass: [number, number, number]; // m, in the flange frame
}

export interface RobotInfo {
  model: string;
  manufacturer: string;
  description: string;
  urdf: string;
  base_link: string;
  flange_link: string;
  tcp: Pose; // in the flange frame
  payload: Payload;
  max_payload: number | null; // kg, the rated payload
  joints: JointLimits[];
  home: number[];
  capabilities: string[];
  digital_inputs: number;
  digital_outputs: number;
}

export interface DeviceDetails extends AddedDevice {
  info: { identity: Record<string, string>; info: RobotInfo } | null;
}

export interface ServiceHealth {
  status: string;
  service?: string;
  version?: string;
  pid?: number;
  uptime_s?: number;
  url?: string;
  message?: string;
}

export interface Health {
  status: string;
  services: Record<string, ServiceHealth>;
}
