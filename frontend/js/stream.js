// The live stream of one mission (`/api/missions/{id}/live`): connect, reconnect, and pass
// each message on. The token goes in the URL only once the server asked for it (close 1008).

import { $, toast } from "./dom.js";
import { getToken } from "./api.js";

export class LiveStream {
  /**
   * onMessage(msg): a parsed message; onNotFound(): the server knows no such mission (4404);
   * retry(): should a dropped stream reconnect (not for a mission that has ended)?
   */
  constructor({ onMessage, onNotFound, retry }) {
    this.onMessage = onMessage;
    this.onNotFound = onNotFound;
    this.retry = retry;
    this.ws = null;
    this.timer = null;
    this.id = null;
  }

  get open() {
    return this.ws !== null;
  }

  connect(id, withToken = false) {
    this.id = id;
    const proto = location.protocol === "https:" ? "wss" : "ws";
    const q = withToken && getToken() ? `?token=${encodeURIComponent(getToken())}` : "";
    const ws = new WebSocket(`${proto}://${location.host}/api/missions/${encodeURIComponent(id)}/live${q}`);
    this.ws = ws;
    this._conn("connecting");
    ws.onopen = () => this._conn("open");
    ws.onmessage = (e) => {
      let msg;
      try {
        msg = JSON.parse(e.data);
      } catch {
        return;
      }
      this.onMessage(msg);
    };
    ws.onclose = (e) => {
      this._conn("closed");
      this.ws = null;
      if (this.id !== id) return undefined;
      if (e.code === 4404) return this.onNotFound();
      const needToken = e.code === 1008;
      if (needToken && (withToken || !getToken())) return toast("This server needs an operator token even to watch.", "error");
      if (!this.retry() && !needToken) return undefined;
      this.timer = setTimeout(() => this.id === id && this.connect(id, needToken || withToken), needToken ? 0 : 1500);
      return undefined;
    };
    ws.onerror = () => {};
  }

  /** Send a message to the server (`{type: "resync"}`); false if the stream is not open. */
  send(msg) {
    if (!this.ws || this.ws.readyState !== WebSocket.OPEN) return false;
    this.ws.send(JSON.stringify(msg));
    return true;
  }

  close() {
    clearTimeout(this.timer);
    this.id = null;
    if (this.ws) {
      this.ws.onclose = null;
      this.ws.close();
      this.ws = null;
    }
  }

  _conn(state) {
    const el = $("#live-conn");
    el.dataset.conn = state;
    el.title = `Stream ${state}`;
  }
}
