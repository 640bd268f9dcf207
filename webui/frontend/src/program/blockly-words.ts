// Blockly's own English, shortened where a long dropdown label makes a block wider than the
// toolbox's flyout on a phone. Set before the first block is made: blocks read Blockly.Msg
// when they are built.
import * as Blockly from "blockly";

const SHORTER: Record<string, string> = {
  TEXT_TRIM_OPERATOR_BOTH: "trim both ends of",
  TEXT_TRIM_OPERATOR_LEFT: "trim the start of",
  TEXT_TRIM_OPERATOR_RIGHT: "trim the end of",
  TEXT_INDEXOF_OPERATOR_FIRST: "find first",
  TEXT_INDEXOF_OPERATOR_LAST: "find last",
};

export function useShorterBlocklyWords(): void {
  Object.assign(Blockly.Msg, SHORTER);
}
