import { css } from "lit";

// Touch-first: every control is at least 48 px tall, text is large, contrast is high.
export const shared = css`
  :host {
    /* The palette comes from the document (index.html, theme.ts). */
    --touch: 56px;
    color: var(--text);
    font-size: 18px;
  }
  * {
    box-sizing: border-box;
  }
  button {
    min-height: var(--touch);
    min-width: var(--touch);
    padding: 0 22px;
    border-radius: 10px;
    border: 2px solid var(--line);
    background: var(--raised);
    color: var(--text);
    font: inherit;
    font-weight: 600;
    cursor: pointer;
    touch-action: manipulation;
    user-select: none;
  }
  button:active {
    transform: translateY(1px);
    filter: brightness(1.2);
  }
  button:disabled {
    opacity: 0.45;
    cursor: default;
  }
  /* A control the role signed in may not use (rights.ts): it still takes the tap that says
     why, so it is aria-disabled, not disabled. */
  [aria-disabled="true"]:not([disabled]):not(:disabled) {
    opacity: 0.45;
    cursor: not-allowed;
  }
  [aria-disabled="true"]:active {
    transform: none;
    filter: none;
  }
  button.primary {
    background: var(--accent);
    border-color: var(--accent);
    color: var(--on-accent);
  }
  button.danger {
    border-color: var(--bad);
    color: var(--bad-fg);
  }
  /* A download link that looks and takes a tap as a button does. */
  a.button {
    display: inline-flex;
    align-items: center;
    min-height: var(--touch);
    padding: 0 22px;
    border-radius: 10px;
    border: 2px solid var(--line);
    background: var(--raised);
    color: var(--text);
    text-decoration: none;
    font-weight: 600;
    touch-action: manipulation;
  }
  input {
    min-height: var(--touch);
    padding: 0 14px;
    border-radius: 10px;
    border: 2px solid var(--line);
    background: var(--bg);
    color: var(--text);
    font: inherit;
    width: 100%;
  }
  input:focus {
    outline: 3px solid var(--accent);
    outline-offset: 1px;
  }
  .card {
    background: var(--panel);
    border: 1px solid var(--line);
    border-radius: 14px;
    padding: 16px;
  }
  .muted {
    color: var(--muted);
  }
  .chip {
    display: inline-flex;
    align-items: center;
    gap: 6px;
    padding: 4px 12px;
    border-radius: 999px;
    font-size: 15px;
    font-weight: 600;
    background: var(--raised);
    white-space: nowrap;
  }
  .chip.ok {
    background: var(--ok-bg);
    color: var(--ok-fg);
  }
  .chip.warn {
    background: var(--warn-bg);
    color: var(--warn-fg);
  }
  .chip.bad {
    background: var(--bad-bg);
    color: var(--bad-fg);
  }
  .dot {
    flex: none;
    width: 12px;
    height: 12px;
    border-radius: 50%;
    display: inline-block;
    background: var(--muted);
  }
  .dot.ok {
    background: var(--ok);
  }
  .dot.warn {
    background: var(--warn);
  }
  .dot.bad {
    background: var(--bad);
  }
  .error {
    color: var(--error-fg);
  }
  h2 {
    font-size: 22px;
    margin: 8px 0 12px;
  }
`;
