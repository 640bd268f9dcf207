// The panels of the app. Adding a panel is a new element plus one entry here.
import { html, type SVGTemplateResult, type TemplateResult } from "lit";
import { t } from "../i18n";
import { icons } from "../icons";
import "./devices-panel";
import "./jog-panel";
import "./program-panel";
import "./scene-panel";
import "./system-panel";

export interface Panel {
  id: string;
  /** The name in the nav, in the chosen language. */
  title: () => string;
  icon: SVGTemplateResult;
  render: () => TemplateResult;
}

export const panels: Panel[] = [
  {
    id: "jog",
    title: () => t("app.panel.jog"),
    icon: icons.jog,
    render: () => html`<op-jog-panel></op-jog-panel>`,
  },
  {
    id: "program",
    title: () => t("app.panel.program"),
    icon: icons.program,
    render: () => html`<op-program-panel></op-program-panel>`,
  },
  {
    id: "scene",
    title: () => t("app.panel.scene"),
    icon: icons.scene,
    render: () => html`<op-scene-panel></op-scene-panel>`,
  },
  {
    id: "devices",
    title: () => t("app.panel.devices"),
    icon: icons.devices,
    render: () => html`<op-devices-panel></op-devices-panel>`,
  },
  {
    id: "system",
    title: () => t("app.panel.system"),
    icon: icons.system,
    render: () => html`<op-system-panel></op-system-panel>`,
  },
];
