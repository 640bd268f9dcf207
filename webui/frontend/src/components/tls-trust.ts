import { LitElement, css, html, svg } from "lit";
import qrcode from "qrcode-generator";
import type { Schemas } from "../api";
import { t } from "../i18n";
import { shared } from "../styles";

type TlsStatus = Schemas["TlsStatus"];

const LOOPBACK = /^(localhost|127\.\d+\.\d+\.\d+|\[::1\])$/;

/** The dark modules of a QR code of `text`, drawn as one SVG path (no markup from a string). */
export function qrPath(text: string): { size: number; path: string } {
  const code = qrcode(0, "M");
  code.addData(text);
  code.make();
  const size = code.getModuleCount();
  let path = "";
  for (let row = 0; row < size; row++) {
    for (let col = 0; col < size; col++) {
      if (code.isDark(row, col)) path += `M${col} ${row}h1v1h-1z`;
    }
  }
  return { size, path };
}

// What a tablet checks before it trusts the UI's HTTPS: the certificate's fingerprint, and
// the runtime's own certificate authority to install (a link, and a QR code of it for a
// tablet's camera). Shown on the set-up screen and the System panel.
export class OpTlsTrust extends LitElement {
  static properties = { tls: { attribute: false } };
  declare tls: TlsStatus | null;

  static styles = [
    shared,
    css`
      .fingerprint {
        font-family: monospace;
        overflow-wrap: anywhere;
      }
      svg {
        width: 176px;
        height: 176px;
        display: block;
      }
    `,
  ];

  constructor() {
    super();
    this.tls = null;
  }

  render() {
    const tls = this.tls;
    if (!tls) return "";
    const url = tls.download ? new URL(tls.download, location.href).href : null;
    // A tablet cannot reach this computer's loopback: its QR code names the LAN address.
    const here = LOOPBACK.test(location.hostname);
    const scanned = here && tls.lan_download ? tls.lan_download : url;
    return html`<div data-testid="tls-trust">
      <p class="hint">${t(tls.authority ? "tls.authority_hint" : "tls.certificate_hint")}</p>
      <p class="fingerprint" data-testid="tls-fingerprint" translate="no">${tls.fingerprint}</p>
      ${url && scanned ? this.download(url, scanned) : ""}
    </div>`;
  }

  private download(url: string, scanned: string) {
    const { size, path } = qrPath(scanned);
    const edge = size + 8; // the quiet zone a reader needs: 4 modules on each side
    return html`<p><a data-testid="tls-download" href=${url} download>${t("tls.download")}</a></p>
      <svg data-testid="tls-qr" viewBox="-4 -4 ${edge} ${edge}" role="img"
        aria-label=${t("tls.qr")} shape-rendering="crispEdges">
        ${svg`<rect x="-4" y="-4" width=${edge} height=${edge} fill="#fff"></rect>
          <path d=${path} fill="#000"></path>`}
      </svg>
      <p class="fingerprint" data-testid="tls-qr-url" translate="no">${scanned}</p>`;
  }
}

customElements.define("op-tls-trust", OpTlsTrust);
