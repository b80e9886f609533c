// A small rosbridge v2 client: the JSON protocol roslibjs speaks, in a few lines, so the page needs no
// library fetched from anywhere. Subscriptions and advertisements survive a reconnection.

export class Bridge {
  constructor(url, { token = null, onOpen = () => {}, onClose = () => {}, onStatus = () => {} } = {}) {
    this.url = url;
    this.token = token;
    this.onOpen = onOpen;
    this.onClose = onClose;
    this.onStatus = onStatus;
    this.handlers = new Map();   // topic -> [callback]
    this.subscriptions = new Map(); // topic -> subscribe op
    this.ws = null;
    this.counter = 0;
    this.retry = 500;
    this.connect();
  }

  connect() {
    const ws = new WebSocket(this.url);
    this.ws = ws;
    ws.onopen = () => {
      this.retry = 500;
      if (this.token) this.send({ op: "auth", mac: this.token, client: "", dest: "", rand: "", t: 0, level: "operator", end: 0 });
      this.send({ op: "set_level", level: "info" });
      for (const op of this.subscriptions.values()) this.send(op);
      this.onOpen();
    };
    ws.onmessage = (event) => {
      let message;
      try { message = JSON.parse(event.data); } catch { return; }
      if (message.op === "publish") {
        for (const callback of this.handlers.get(message.topic) || []) callback(message.msg);
      } else if (message.op === "status") {
        this.onStatus(message);
      }
    };
    ws.onclose = (event) => {
      this.onClose(event);
      setTimeout(() => this.connect(), this.retry);
      this.retry = Math.min(this.retry * 2, 5000);
    };
  }

  get open() { return this.ws && this.ws.readyState === WebSocket.OPEN; }

  send(op) {
    if (this.open) this.ws.send(JSON.stringify(op));
  }

  subscribe(topic, type, callback, options = {}) {
    if (!this.handlers.has(topic)) this.handlers.set(topic, []);
    this.handlers.get(topic).push(callback);
    if (!this.subscriptions.has(topic)) {
      const op = { op: "subscribe", id: `subscribe:${topic}:${++this.counter}`, topic, type, ...options };
      this.subscriptions.set(topic, op);
      this.send(op);
    }
  }

  publish(topic, msg) {
    this.send({ op: "publish", topic, msg });
  }
}
