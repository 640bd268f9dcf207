// The program service's models (runtime/program/models.py), by their names in the API's
// document (see api.ts).

import type { Schemas } from "../api";

export type ProgramSummary = Schemas["ProgramSummary"];
export type Program = Schemas["Program"];
/** What keeps a program from running, at a block: an empty input, a loose block. */
export type Problem = Schemas["ProblemInfo"];
export type Saved = Schemas["Saved"];
export type Generated = Schemas["Generated"];
export type RunStatus = Schemas["RunStatus"];
export type RunState = RunStatus["state"];
export type OutputEntry = Schemas["OutputEntry"];
export type RunError = Schemas["ErrorInfo"];

export const LIVE_STATES: RunState[] = ["starting", "running", "paused"];
