// Shapes of the program service's API (see runtime/program/models.py).

import type { Words } from "../i18n/words";

export interface ProgramSummary {
  name: string;
  source: "blocks" | "python";
  version: number;
  updated: number;
}

export interface Program extends ProgramSummary {
  workspace: unknown;
  python: string;
}

/** What keeps a program from running, at a block: an empty input, a loose block. */
export interface Problem {
  block: string;
  message: string;
  words?: Words | null;
}

export interface Saved {
  name: string;
  python: string;
  version: number;
  blocks: number;
  problems: Problem[];
}

export interface Generated {
  python: string;
  blocks: number;
  problems: Problem[];
}

export type RunState =
  | "idle"
  | "starting"
  | "running"
  | "paused"
  | "stopped"
  | "error"
  | "finished";

export interface OutputEntry {
  seq: number;
  text: string;
  stream: string;
  block: string | null;
  ts: number;
  words?: Words | null;
}

export interface RunError {
  message: string;
  kind: string;
  line: number | null;
  block: string | null;
  code: string | null;
  words?: Words | null;
}

export interface RunStatus {
  program: string;
  run: number;
  state: RunState;
  block: string | null;
  pause_reason: string;
  message: string;
  output: OutputEntry[];
  error: RunError | null;
  robots: string[];
  started: number | null;
  ended: number | null;
}

export const LIVE_STATES: RunState[] = ["starting", "running", "paused"];
