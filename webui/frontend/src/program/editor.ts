// A Blockly workspace for one program: load and serialise, highlight the running block,
// breakpoints (block context menu or the panel's button), undo/redo. Touch-first options.

import * as Blockly from "blockly";
import { t } from "../i18n";
import { worded } from "../i18n/words";
import { currentTheme, paletteColour } from "../theme";
import { applyBlocklyLanguage, localizedToolbox } from "./blockly-words";
import { rememberNames, type BlockCatalog, defineBlocks } from "./catalog";
import type { Problem } from "./types";

const BREAKPOINT_CLASS = "opBreakpoint";

/** Blockly's colours from the palette in use (Blockly draws on SVG, outside our CSS). */
function blocklyTheme(): Blockly.Theme {
  const light = currentTheme() === "light";
  const name = light ? "openpendant-light" : "openpendant-dark";
  return Blockly.Theme.defineTheme(name, {
    name,
    base: Blockly.Themes.Classic,
    componentStyles: {
      workspaceBackgroundColour: paletteColour("--bg"),
      toolboxBackgroundColour: paletteColour("--panel"),
      toolboxForegroundColour: paletteColour("--text"),
      flyoutBackgroundColour: paletteColour("--raised"),
      flyoutForegroundColour: paletteColour("--text"),
      flyoutOpacity: 0.96,
      scrollbarColour: light ? "#8a97a6" : "#5b6b7d",
      insertionMarkerColour: light ? "#000000" : "#ffffff",
      insertionMarkerOpacity: 0.35,
      cursorColour: paletteColour("--accent"),
    },
    fontStyle: { family: "system-ui, sans-serif", size: 13 },
  });
}

const editors = new Map<string, ProgramEditor>(); // workspace id -> editor

function canBreak(block: Blockly.BlockSvg): boolean {
  // Statements carry the markers the worker pauses at; values are part of a statement.
  return block.previousConnection !== null || block.nextConnection !== null;
}

/** One line of the program outline: a statement block, indented under what contains it. */
export interface OutlineItem {
  id: string;
  text: string;
  depth: number;
}

/** A statement as one line: its own fields and values, not the statements inside it. */
function headline(block: Blockly.Block): string {
  const parts: string[] = [];
  for (const input of block.inputList) {
    for (const field of input.fieldRow) {
      const text = field.getText();
      if (text) parts.push(text);
    }
    if (input.type === Blockly.inputs.inputTypes.VALUE) {
      parts.push(input.connection?.targetBlock()?.toString(30) ?? "?");
    }
  }
  const text = parts.join(" ").replace(/\s+/g, " ").trim();
  return text.length > 80 ? `${text.slice(0, 79)}…` : text;
}

let menuRegistered = false;

function registerBreakpointMenu(): void {
  if (menuRegistered) return;
  menuRegistered = true;
  Blockly.ContextMenuRegistry.registry.register({
    id: "openpendant_breakpoint",
    scopeType: Blockly.ContextMenuRegistry.ScopeType.BLOCK,
    weight: -10,
    displayText: (scope) => {
      const block = scope.block;
      const on = block !== undefined && editors.get(block.workspace.id)?.breakpoints.has(block.id);
      return on ? t("program.breakpoint.remove") : t("program.breakpoint.add");
    },
    preconditionFn: (scope) =>
      scope.block && canBreak(scope.block) && editors.has(scope.block.workspace.id)
        ? "enabled"
        : "hidden",
    callback: (scope) => {
      const block = scope.block;
      if (block) editors.get(block.workspace.id)?.toggleBreakpoint(block.id);
    },
  });
}

export class ProgramEditor extends EventTarget {
  readonly breakpoints = new Set<string>();
  private readonly workspace: Blockly.WorkspaceSvg;
  private readonly resizer: ResizeObserver;

  constructor(container: HTMLElement, catalog: BlockCatalog, compact: boolean) {
    super();
    applyBlocklyLanguage();
    defineBlocks(catalog);
    registerBreakpointMenu();
    this.workspace = Blockly.inject(container, {
      toolbox: localizedToolbox(catalog.toolbox),
      theme: blocklyTheme(),
      renderer: "zelos",
      media: "./blockly-media/",
      sounds: false,
      // Inline editing: the browser's prompt() is no good on a pendant.
      modalInputs: false,
      trashcan: true,
      grid: { spacing: 32, length: 2, colour: paletteColour("--line"), snap: true },
      move: { scrollbars: true, drag: true, wheel: true },
      zoom: {
        controls: true,
        wheel: false,
        pinch: true,
        startScale: compact ? 0.6 : 0.8,
        maxScale: 2,
        minScale: 0.3,
        scaleSpeed: 1.2,
      },
    });
    editors.set(this.workspace.id, this);
    this.workspace.addChangeListener((event) => this.onEvent(event));
    this.resizer = new ResizeObserver(() => Blockly.svgResize(this.workspace));
    window.addEventListener("op-theme", this.retheme);
    this.resizer.observe(container);
  }

  /** Replaces the workspace's blocks; the undo history starts afresh. */
  load(state: unknown): void {
    this.workspace.clear();
    this.breakpoints.clear();
    if (state && typeof state === "object") {
      rememberNames(state);
      Blockly.serialization.workspaces.load(state as object, this.workspace);
    }
    this.workspace.clearUndo();
    this.workspace.scrollCenter();
    this.changed("history");
  }

  state(): Record<string, unknown> {
    return Blockly.serialization.workspaces.save(this.workspace);
  }

  isEmpty(): boolean {
    return this.workspace.getAllBlocks(false).length === 0;
  }

  /** The running block (null: none); scrolled into view if it is off screen. */
  highlight(id: string | null): void {
    this.workspace.highlightBlock(id);
    const block = id ? this.workspace.getBlockById(id) : null;
    if (block && !this.visible(block)) this.workspace.centerOnBlock(block.id);
  }

  /** Selects a block and brings it into view (an error's block). */
  reveal(id: string): void {
    const block = this.workspace.getBlockById(id);
    if (!block) return;
    this.workspace.centerOnBlock(id);
    // Through common.setSelected: block.select() alone only paints it, and fires no event.
    if (block instanceof Blockly.BlockSvg) Blockly.common.setSelected(block);
  }

  /** Warnings on the blocks that keep the program from running; cleared on the rest. */
  warn(problems: Problem[]): void {
    const messages = new Map<string, string[]>();
    for (const p of problems) {
      messages.set(p.block, [...(messages.get(p.block) ?? []), worded(p.message, p.words)]);
    }
    for (const block of this.workspace.getAllBlocks(false)) {
      const text = messages.get(block.id)?.join("\n") ?? null;
      block.setWarningText(text);
    }
  }

  /** The program as a tree of statements, top to bottom, the way it runs. */
  outline(): OutlineItem[] {
    const items: OutlineItem[] = [];
    const walk = (first: Blockly.Block | null, depth: number) => {
      for (let block = first; block; block = block.getNextBlock()) {
        items.push({ id: block.id, text: headline(block), depth });
        for (const input of block.inputList) {
          if (input.type !== Blockly.inputs.inputTypes.STATEMENT) continue;
          walk(input.connection?.targetBlock() ?? null, depth + 1);
        }
      }
    };
    for (const top of this.workspace.getTopBlocks(true)) walk(top, 0);
    return items;
  }

  /** A block as text ("wait 0.2 s"), for the status line. */
  describe(id: string): string {
    return this.workspace.getBlockById(id)?.toString(40) ?? "";
  }

  selectedBlock(): string | null {
    const selected = Blockly.common.getSelected();
    return selected instanceof Blockly.BlockSvg && canBreak(selected) ? selected.id : null;
  }

  toggleBreakpoint(id: string): void {
    const block = this.workspace.getBlockById(id);
    if (!block || !canBreak(block)) return;
    if (this.breakpoints.has(id)) {
      this.breakpoints.delete(id);
      block.removeClass(BREAKPOINT_CLASS);
    } else {
      this.breakpoints.add(id);
      block.addClass(BREAKPOINT_CLASS);
    }
    this.changed("breakpoints");
  }

  /** Breakpoints on blocks that still exist. */
  liveBreakpoints(): string[] {
    return [...this.breakpoints].filter((id) => this.workspace.getBlockById(id) !== null);
  }

  undo(redo: boolean): void {
    this.workspace.undo(redo);
  }

  canUndo(): boolean {
    return this.workspace.getUndoStack().length > 0;
  }

  canRedo(): boolean {
    return this.workspace.getRedoStack().length > 0;
  }

  private readonly retheme = () => this.workspace.setTheme(blocklyTheme());

  dispose(): void {
    window.removeEventListener("op-theme", this.retheme);
    this.resizer.disconnect();
    editors.delete(this.workspace.id);
    this.workspace.dispose();
  }

  private visible(block: Blockly.BlockSvg): boolean {
    const view = this.workspace.getMetricsManager().getViewMetrics(true);
    const box = block.getBoundingRectangle();
    return (
      box.top >= view.top &&
      box.left >= view.left &&
      box.bottom <= view.top + view.height &&
      box.right <= view.left + view.width
    );
  }

  private onEvent(event: Blockly.Events.Abstract): void {
    if (event.type === Blockly.Events.SELECTED) this.changed("selection");
    if (event.isUiEvent) return;
    if (event instanceof Blockly.Events.BlockCreate) {
      // Undoing a delete brings the block back under its old id: so does its breakpoint.
      for (const id of event.ids ?? []) {
        if (this.breakpoints.has(id)) this.workspace.getBlockById(id)?.addClass(BREAKPOINT_CLASS);
      }
    }
    this.changed("blocks");
    this.changed("history");
  }

  private changed(what: "blocks" | "history" | "breakpoints" | "selection"): void {
    this.dispatchEvent(new Event(what));
  }
}
