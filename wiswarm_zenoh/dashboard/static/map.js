// The tracking app's arena, drawn on a canvas: each UAV's car (a square), the UAV (a
// triangle pointing along its heading), its camera's footprint on the ground and the
// waypoints it was sent. From each UAV's JSON on wiswarm/<swarm>/<uav>/tracking.

const STALE_S = 2.0;  // a UAV not heard from this long is drawn faded
const MARGIN_PX = 24;

export class ArenaMap {
  constructor(canvas, colourOf) {
    this.canvas = canvas;
    this.colourOf = colourOf;
    this.uavs = new Map();  // uav -> {record, heard (page time, s)}
  }

  reset(records, now) {
    this.uavs.clear();
    for (const record of records) this.set(record, now);
  }

  set(record, now) {
    this.uavs.set(record.uav, {record, heard: now});
    this.canvas.parentElement.hidden = false;
  }

  arena() {
    for (const {record} of this.uavs.values()) if (record.arena) return record.arena;
    return [20, 10];
  }

  draw(now) {
    if (this.uavs.size === 0) return;
    const [width, height] = this.arena();
    const cssWidth = Math.min(900, this.canvas.parentElement.clientWidth - 4);
    const scale = (cssWidth - 2 * MARGIN_PX) / width;
    const cssHeight = height * scale + 2 * MARGIN_PX;
    const ratio = window.devicePixelRatio || 1;
    if (this.canvas.width !== Math.round(cssWidth * ratio)) {
      this.canvas.width = Math.round(cssWidth * ratio);
      this.canvas.height = Math.round(cssHeight * ratio);
      this.canvas.style.height = `${cssHeight}px`;
    }
    const ctx = this.canvas.getContext("2d");
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    ctx.clearRect(0, 0, cssWidth, cssHeight);
    const px = (x, y) => [MARGIN_PX + x * scale, MARGIN_PX + (height - y) * scale];
    this.grid(ctx, px, width, height);
    for (const [uav, {record, heard}] of [...this.uavs].sort()) {
      ctx.globalAlpha = now - heard > STALE_S ? 0.3 : 1.0;
      this.drawUav(ctx, px, uav, record, this.colourOf(uav), scale);
    }
    ctx.globalAlpha = 1.0;
  }

  grid(ctx, px, width, height) {
    ctx.strokeStyle = "#eee";
    ctx.lineWidth = 1;
    for (let x = 0; x <= width; x++) line(ctx, [px(x, 0), px(x, height)]);
    for (let y = 0; y <= height; y++) line(ctx, [px(0, y), px(width, y)]);
    ctx.strokeStyle = "#888";
    ctx.strokeRect(...px(0, height), width * (px(1, 0)[0] - px(0, 0)[0]),
                   height * (px(0, 0)[1] - px(0, 1)[1]));
    ctx.fillStyle = "#888";
    ctx.font = "11px system-ui, sans-serif";
    ctx.fillText(`${width} m x ${height} m`, ...px(0, -0.15));
  }

  drawUav(ctx, px, uav, r, colour, scale) {
    if (r.footprint) {
      ctx.fillStyle = colour;
      ctx.globalAlpha *= 0.15;
      polygon(ctx, r.footprint.map(([x, y]) => px(x, y)));
      ctx.fill();
      ctx.globalAlpha /= 0.15;
    }
    if (r.waypoints && r.waypoints.length) {
      ctx.strokeStyle = colour;
      ctx.setLineDash([4, 3]);
      const points = r.waypoints.map(([, x, y]) => px(x, y));
      line(ctx, r.x === undefined ? points : [px(r.x, r.y), ...points]);
      ctx.setLineDash([]);
      ctx.fillStyle = colour;
      for (const [x, y] of points) ctx.fillRect(x - 1.5, y - 1.5, 3, 3);
    }
    if (r.car_x !== undefined) {
      const [x, y] = px(r.car_x, r.car_y);
      const side = Math.max(6, 0.4 * scale);
      ctx.fillStyle = "#333";
      ctx.fillRect(x - side / 2, y - side / 2, side, side);
      ctx.fillStyle = colour;
      ctx.fillRect(x - side / 4, y - side / 4, side / 2, side / 2);
    }
    if (r.x !== undefined) {
      const [x, y] = px(r.x, r.y);
      const yaw = r.yaw || 0;
      const tip = (angle, length) => [x + length * Math.cos(angle),
                                      y - length * Math.sin(angle)];
      ctx.fillStyle = colour;
      polygon(ctx, [tip(yaw, 12), tip(yaw + 2.5, 8), tip(yaw - 2.5, 8)]);
      ctx.fill();
      ctx.fillStyle = "#222";
      ctx.font = "12px system-ui, sans-serif";
      ctx.fillText(uav, x + 10, y - 10);
    }
  }
}

function line(ctx, points) {
  ctx.beginPath();
  points.forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
  ctx.stroke();
}

function polygon(ctx, points) {
  ctx.beginPath();
  points.forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
  ctx.closePath();
}
