import { css } from "lit";

// What the Vision panel's steps share: number fields in a grid, lists of frames or poses,
// and an operation's progress.
export const visionStyles = css`
  :host {
    display: block;
  }
  .fields {
    display: grid;
    grid-template-columns: repeat(auto-fill, minmax(140px, 1fr));
    gap: 10px;
    margin: 10px 0;
  }
  label {
    display: flex;
    flex-direction: column;
    gap: 4px;
    font-size: 15px;
    color: var(--muted);
  }
  select {
    min-height: var(--touch);
    border-radius: 10px;
    border: 2px solid var(--line);
    background: var(--bg);
    color: var(--text);
    font: inherit;
    padding: 0 10px;
  }
  .actions {
    display: flex;
    flex-wrap: wrap;
    gap: 10px;
    margin: 10px 0;
  }
  .operation {
    display: flex;
    flex-wrap: wrap;
    align-items: center;
    gap: 10px;
    margin: 10px 0;
  }
  progress {
    flex: 1 1 160px;
    height: 20px;
  }
  ul.rows {
    list-style: none;
    margin: 8px 0;
    padding: 0;
    display: flex;
    flex-direction: column;
    gap: 6px;
  }
  ul.rows li {
    display: flex;
    align-items: center;
    justify-content: space-between;
    gap: 10px;
    padding: 4px 4px 4px 12px;
    border: 1px solid var(--line);
    border-radius: 10px;
    font-variant-numeric: tabular-nums;
  }
  ul.rows li[data-outlier="true"] {
    border-color: var(--warn);
  }
  .quality {
    display: grid;
    grid-template-columns: auto 1fr;
    gap: 4px 14px;
    margin: 10px 0;
    font-variant-numeric: tabular-nums;
  }
  .quality dt {
    color: var(--muted);
  }
  .quality dd {
    margin: 0;
  }
  .hints {
    margin: 8px 0;
    padding-left: 22px;
  }
  .chips {
    display: flex;
    flex-wrap: wrap;
    gap: 6px;
    margin: 8px 0;
  }
  h3 {
    margin: 6px 0;
  }
`;

// A file chooser that looks and works as a button (its input hidden inside its label).
export const fileButton = css`
  .file {
    display: inline-flex;
    align-items: center;
    min-height: var(--touch);
    padding: 0 18px;
    border-radius: 10px;
    border: 2px solid var(--line);
    background: var(--raised);
    color: var(--text);
    font-weight: 600;
    cursor: pointer;
    text-decoration: none;
  }
  .file input {
    display: none;
  }
`;
