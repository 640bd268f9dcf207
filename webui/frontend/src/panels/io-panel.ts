import { LitElement, css, html } from "lit";
import { client, errorText, ok } from "../api";
import { control, leaseRequest } from "../control";
import { t } from "../i18n";
import { Listening } from "../listening";
import { FeedController, feed } from "../live";
import { makes, request } from "../rights";
import { shared } from "../styles";
import type { AddedDevice } from "../types";

interface SignalInfo {
  name: string;
  kind: "digital_input" | "digital_output" | "analog_input" | "analog_output";
  unit: string;
  minimum: number | null;
  maximum: number | null;
  description: string;
}

interface IOState {
  connected: boolean;
  values: Record<string, boolean | number | null>;
  error: string;
}

/** An I/O block's details: its driver's info names its signals (DeviceDetails has any
 * kind's info). */
type Details = { info: { info: { signals?: SignalInfo[] } } | null };

/** A signal's name with a line break allowed after each "_", "." and "-" (the words of
 * `part_present_sensor_2`), and nowhere else while its words fit; a word of one or
 * two letters stays with the one before it, never on a line of its own. */
function breakable(name: string) {
  return name.split(/(?<=[_.-])/).map((word, i) => (i && word.length > 2 ? html`<wbr>${word}` : word));
}

// Every signal of every I/O block, live from the device feed; outputs switched here only
// by the pendant that has control of the block (as a robot is jogged only with control).
export class OpIoPanel extends LitElement {
  static properties = {
    signals: { state: true },
    error: { state: true },
  };
  declare signals: Map<string, SignalInfo[]>;
  declare error: string;
  private readonly onControl = () => this.requestUpdate();

  static styles = [
    shared,
    css`
      .signals {
        display: grid;
        grid-template-columns: repeat(auto-fill, minmax(220px, 1fr));
        gap: 10px;
      }
      /* A name too long to share its line with the value and the controls gets the line to
         itself (they go under it, on the right) rather than be squeezed to a letter a line;
         it breaks after its underscores, between its words. */
      .signal {
        display: flex;
        flex-wrap: wrap;
        align-items: center;
        justify-content: space-between;
        gap: 6px 10px;
        min-height: var(--touch);
        padding: 6px 12px;
        border: 1px solid var(--line);
        border-radius: 10px;
      }
      .signal .name {
        flex: 1 1 auto;
        min-width: 0;
        overflow-wrap: break-word;
      }
      .reading {
        display: flex;
        flex-wrap: wrap;
        align-items: center;
        justify-content: flex-end;
        gap: 6px 10px;
        margin-left: auto;
        min-width: 0;
      }
      .value {
        font-weight: 700;
        font-variant-numeric: tabular-nums;
      }
      .value[data-state="on"] {
        color: var(--ok);
      }
      .value[data-state="unknown"] {
        color: var(--muted);
      }
      .signal button {
        min-width: 88px;
      }
      .signal button[aria-pressed="true"] {
        border-color: var(--ok);
        color: var(--ok);
      }
      .analog {
        display: flex;
        gap: 6px;
        align-items: center;
      }
      .analog input {
        width: 90px;
      }
      header {
        display: flex;
        align-items: center;
        justify-content: space-between;
        flex-wrap: wrap;
        gap: 10px;
        margin-bottom: 10px;
      }
    `,
  ];

  constructor() {
    super();
    new Listening(this, control, "change", this.onControl);
    new FeedController(this);
    this.signals = new Map();
    this.error = "";
  }

  private blocks(): AddedDevice[] {
    return feed.devices.filter((d) => d.kind === "io");
  }

  /** Each block's signals, read once from its description (they do not change). */
  private async describe(name: string): Promise<void> {
    try {
      const details = (await ok(client.GET("/api/devices/{local_name}",
        { params: { path: { local_name: name } } }))) as Details;
      const signals = details.info?.info.signals;
      if (signals) this.signals = new Map(this.signals).set(name, signals);
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private async act(work: () => Promise<unknown>): Promise<void> {
    this.error = "";
    try {
      await work();
    } catch (err) {
      this.error = errorText(err);
    }
  }

  private write(device: string, signal: string, value: boolean | number): void {
    const token = control.token(device);
    void this.act(() =>
      ok(client.POST("/api/devices/{local_name}/call/{method}", {
        params: { path: { local_name: device, method: "write" }, header: { "X-Lease-Token": token } },
        body: { args: [signal], body: { value } },
      })),
    );
  }

  private setAnalog(e: Event, device: string, signal: string): void {
    e.preventDefault();
    const input = (e.target as HTMLFormElement).querySelector("input");
    const value = Number(input?.value);
    if (input && input.value.trim() !== "" && Number.isFinite(value)) this.write(device, signal, value);
  }

  private shown(s: SignalInfo, value: boolean | number | null | undefined) {
    if (value === null || value === undefined) {
      return html`<span class="value" data-state="unknown">${t("io.unknown")}</span>`;
    }
    if (typeof value === "boolean") {
      return html`<span class="value" data-state=${value ? "on" : "off"}
        >${value ? t("io.on") : t("io.off")}</span>`;
    }
    return html`<span class="value">${Number(value.toFixed(3))} ${s.unit}</span>`;
  }

  private signal(device: string, s: SignalInfo, state: IOState | undefined, mine: boolean) {
    const value = state?.values[s.name];
    const id = `${device}-${s.name}`;
    const writes = makes(request("POST", `/api/devices/${encodeURIComponent(device)}/call/write`));
    let control_ = html``;
    if (s.kind === "digital_output") {
      control_ = html`<button data-testid="toggle-${id}" aria-pressed=${value === true}
        ?disabled=${!mine || typeof value !== "boolean"} ${writes}
        @click=${() => this.write(device, s.name, !value)}>${value ? t("io.off") : t("io.on")}</button>`;
    } else if (s.kind === "analog_output") {
      control_ = html`<form class="analog" @submit=${(e: Event) => this.setAnalog(e, device, s.name)}>
        <input type="number" step="any" inputmode="decimal" data-testid="value-${id}"
          min=${s.minimum ?? ""} max=${s.maximum ?? ""} ?disabled=${!mine} />
        <button type="submit" ?disabled=${!mine} ${writes}>${t("io.set")}</button>
      </form>`;
    }
    return html`<div class="signal" data-testid="signal-${id}" title=${s.description}
      data-value=${value === null || value === undefined ? "unknown" : String(value)}>
      <span class="name" translate="no">${breakable(s.name)}</span>
      <span class="reading">${this.shown(s, value)} ${control_}</span>
    </div>`;
  }

  private block(d: AddedDevice) {
    const signals = this.signals.get(d.local_name);
    if (signals === undefined) void this.describe(d.local_name);
    const state = feed.states.get(d.local_name) as unknown as IOState | undefined;
    const mine = control.holds(d.local_name);
    const holder = d.controlled_by;
    return html`<section class="card" data-testid="io-block" data-name=${d.local_name}>
      <header>
        <h3 translate="no">${d.local_name}</h3>
        <span data-testid="io-status-${d.local_name}"
          >${state?.error || (state?.connected ? "" : t("io.disconnected"))}</span>
        ${mine
          ? html`<button data-testid="io-release-${d.local_name}" ${makes(leaseRequest(d.local_name, true))}
              @click=${() => this.act(() => control.release(d.local_name))}>${t("jog.control.release")}</button>`
          : html`<span>${holder ? t("jog.control.controlled_by", { holder }) : ""}</span>
              <button class="primary" data-testid="io-control-${d.local_name}"
                ${makes(leaseRequest(d.local_name))}
                @click=${() => this.act(() => control.take(d.local_name))}>${t("jog.control.take")}</button>`}
      </header>
      <div class="signals">
        ${(signals ?? []).map((s) => this.signal(d.local_name, s, state, mine))}
      </div>
    </section>`;
  }

  render() {
    const blocks = this.blocks();
    return html`
      ${this.error ? html`<p class="error" role="alert" data-testid="io-error">${this.error}</p>` : ""}
      <h2>${t("app.panel.io")}</h2>
      ${blocks.length
        ? blocks.map((d) => this.block(d))
        : html`<p class="card" data-testid="io-none">${t("io.none")}</p>`}
    `;
  }
}

customElements.define("op-io-panel", OpIoPanel);
