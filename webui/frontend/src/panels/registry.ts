// The panels of the app. Adding a panel is a new element plus one entry here.
import { html, type SVGTemplateResult, type TemplateResult } from "lit";
import { icons } from "../icons";
import "./devices-panel";
import "./jog-panel";
import "./program-panel";
import "./scene-panel";
import "./system-panel";

export interface Panel {
  id: string;
  title: string;
  icon: SVGTemplateResult;
  render: () => TemplateResult;
}

export const panels: Panel[] = [
  {
    id: "jog",
    title: "Jog",
    icon: icons.jog,
    render: () => html`<op-jog-panel></op-jog-panel>`,
  },
  {
    id: "program",
    title: "Program",
    icon: icons.program,
    render: () => html`<op-program-panel></op-program-panel>`,
  },
  {
    id: "scene",
    title: "Scene",
    icon: icons.scene,
    render: () => html`<op-scene-panel></op-scene-panel>`,
  },
  {
    id: "devices",
    title: "Devices",
    icon: icons.devices,
    render: () => html`<op-devices-panel></op-devices-panel>`,
  },
  {
    id: "system",
    title: "System",
    icon: icons.system,
    render: () => html`<op-system-panel></op-system-panel>`,
  },
];
