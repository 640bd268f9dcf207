import { css } from "lit";

// Blockly draws inside the Program panel's shadow root: its own CSS lands there, and so does
// this, for the panel to add to its styles. Touch-sized toolbox rows and dropdown rows, the
// breakpoint and the running block.
export const blocklyStyles = css`
  /* Blockly's dropdown menus: rows a finger can hit. */
  .blocklyDropDownDiv .blocklyMenuItem,
  .blocklyWidgetDiv .blocklyMenuItem {
    min-height: 48px;
    display: flex;
    align-items: center;
    font-size: 17px;
  }
  .blocklyToolboxCategory {
    min-height: 46px;
    display: flex;
    align-items: center;
  }
  .blocklyToolboxCategoryLabel {
    font-size: 18px;
    padding: 0 10px;
  }
  .blocklyToolbox {
    min-width: 140px;
  }
  .opBreakpoint > .blocklyPath {
    stroke: #f85149 !important;
    stroke-width: 5px !important;
    stroke-dasharray: 8 4;
  }
  .blocklyHighlighted > .blocklyPath {
    stroke: #f5a524 !important;
    stroke-width: 6px !important;
  }
  @media (max-width: 700px) {
    /* A narrow toolbox leaves the flyout room for the widest block (the pose). */
    .blocklyToolbox {
      min-width: 0;
      max-width: 112px;
    }
    .blocklyToolboxCategoryLabel {
      font-size: 15px;
      padding: 0 4px;
      white-space: normal;
      line-height: 1.15;
    }
  }
`;
