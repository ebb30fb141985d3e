// The exact AoI sawtooth of every follower over the last window, from the leader's
// delivery stream: at each delivery the age drops to (delivery - generation) of the
// freshest update so far, and between deliveries it climbs at slope 1. One uPlot chart
// in its "mode 2" (each series has x and y of its own: followers are delivered at
// different times), redrawn every animation frame as time moves.
//
// The stream comes in batches (10 Hz), each with every event up to when it was sent:
// the ages are known up to the latest event heard (``known``), not up to "now". The
// sawtooth stops there, a batch period or so short of the window's right edge ("now"),
// rather than climb past deliveries still on their way.

const PRUNE_EVERY_S = 1.0;  // how often points older than the window are dropped
const CROSS_PX = 3.5;  // half the size of an unanswered poll's mark

export function colour(index) {
  return `hsl(${(index * 137.508) % 360}, 65%, 45%)`;
}

function crosses(u, seriesIdx) {
  // uPlot's path builder for the unanswered polls: a cross at each (its own points
  // builder draws nothing in mode 2).
  const [xs, ys] = u.data[seriesIdx];
  const r = CROSS_PX * devicePixelRatio;
  const stroke = new Path2D();
  for (let i = 0; i < xs.length; i++) {
    const x = u.valToPos(xs[i], "x", true);
    const y = u.valToPos(ys[i], "y", true);
    stroke.moveTo(x - r, y - r);
    stroke.lineTo(x + r, y + r);
    stroke.moveTo(x - r, y + r);
    stroke.lineTo(x + r, y - r);
  }
  return {stroke, fill: null, clip: null, band: null, gaps: null, flags: 0};
}

class Trace {
  // One follower: the sawtooth's corners and, once it has one, a last corner at "now"
  // (the tail), moved every frame. uPlot draws these very arrays: changed in place.
  constructor(tau, colour) {
    this.colour = colour;
    this.xs = [];
    this.ys = [];
    this.tau = tau;  // the freshest generation time delivered so far (null: none)
    this.tailed = false;
  }

  corner(x, y) {
    if (this.tailed) {
      this.xs.pop();
      this.ys.pop();
      this.tailed = false;
    }
    this.xs.push(x);
    this.ys.push(y);
  }

  add(generated, delivered, timeouts) {
    if (generated === null) {  // an unanswered poll: marked at the age it left
      if (this.tau !== null) {
        timeouts[0].push(delivered);
        timeouts[1].push(delivered - this.tau);
      }
      return;
    }
    if (this.tau !== null) this.corner(delivered, delivered - this.tau);  // the peak
    if (this.tau === null || generated > this.tau) this.tau = generated;
    this.corner(delivered, delivered - this.tau);  // the drop
  }

  tail(now, from) {
    // Returns the age now (null: nothing delivered yet). A follower delivered before
    // the window only climbs all through it: from its left edge.
    if (this.tau === null) return null;
    if (this.xs.length === 0) this.corner(from, from - this.tau);
    if (!this.tailed) {
      this.xs.push(now);
      this.ys.push(now - this.tau);
      this.tailed = true;
    }
    const last = this.xs.length - 1;
    this.xs[last] = now;
    this.ys[last] = now - this.tau;
    return this.ys[last];
  }

  prune(from) {
    // Keep one corner before ``from``, so that the line enters the window at its edge.
    let i = 0;
    while (i + 1 < this.xs.length && this.xs[i + 1] < from) i++;
    if (i > 0) {
      this.xs.splice(0, i);
      this.ys.splice(0, i);
    }
  }
}

export class Sawtooth {
  constructor(element, windowS, onDraw) {
    this.element = element;
    this.windowS = windowS;
    this.traces = new Map();  // follower -> Trace, in the order of their series
    this.timeouts = [[], []];
    this.yMax = 0;
    this.prunedAt = 0;
    this.known = -Infinity;  // the latest event heard (leader clock)
    this.data = [null, this.timeouts];
    this.plot = new uPlot({
      mode: 2,
      width: this.width(),
      height: 320,
      legend: {show: false},
      cursor: {show: false},
      scales: {x: {time: true, auto: false}, y: {auto: false}},
      axes: [{}, {label: "AoI (s)", size: 60}],
      series: [{}, {
        label: "unanswered poll", stroke: "#b3261e", width: 1.5, paths: crosses,
        points: {show: false},
        facets: [{scale: "x", auto: false}, {scale: "y", auto: false}],
      }],
      hooks: {draw: [() => onDraw()]},
    }, this.data, element);
    window.addEventListener("resize", () => this.plot.setSize(
      {width: this.width(), height: 320}));
  }

  width() {
    return Math.max(400, this.element.parentElement.clientWidth - 4);
  }

  reset(traces) {
    // A snapshot: every follower's deliveries of the last window.
    for (let i = this.data.length - 1; i >= 2; i--) this.plot.delSeries(i);
    this.traces.clear();
    this.known = -Infinity;
    this.timeouts[0].length = 0;
    this.timeouts[1].length = 0;
    this.data.length = 2;  // the plot holds this array: changed in place, never replaced
    for (const [follower, trace] of Object.entries(traces)) {
      this.trace(follower, trace.tau);
      this.add(trace.records.map(([generated, delivered]) => [follower, generated, delivered]));
    }
    // In time order, as later ones come (they are pruned from the oldest).
    const order = this.timeouts[0].map((x, i) => i).sort(
      (a, b) => this.timeouts[0][a] - this.timeouts[0][b]);
    for (const values of this.timeouts) {
      const sorted = order.map((i) => values[i]);
      sorted.forEach((value, i) => { values[i] = value; });
    }
  }

  trace(follower, tau = null) {
    let t = this.traces.get(follower);
    if (t === undefined) {
      const index = this.traces.size;
      t = new Trace(tau, colour(index));
      this.traces.set(follower, t);
      this.plot.addSeries({
        label: follower, stroke: t.colour, width: 1,  // 1: Skia's hairlines, the fastest
        points: {show: false},
        facets: [{scale: "x", auto: false}, {scale: "y", auto: false}],
      }, index + 2);
      this.data.push([t.xs, t.ys]);
    }
    return t;
  }

  add(records) {
    for (const [follower, generated, delivered] of records) {
      this.trace(follower).add(generated, delivered, this.timeouts);
      if (delivered > this.known) this.known = delivered;
    }
  }

  age(follower) {
    // The follower's age at the latest event heard.
    const t = this.traces.get(follower);
    return t === undefined || t.tau === null ? null : this.known - t.tau;
  }

  draw(now, present = null) {
    // One frame: the window ends at ``now`` (the leader's clock); tails climb to ``known``.
    // The y axis fits the followers ``present`` (a Set; null: all): one that left keeps
    // its growing age, drawn off the top, and does not squash the others' sawtooth.
    const from = now - this.windowS;
    if (now - this.prunedAt >= PRUNE_EVERY_S) {
      this.prunedAt = now;
      for (const t of this.traces.values()) t.prune(from);
      let i = 0;
      while (i < this.timeouts[0].length && this.timeouts[0][i] < from) i++;
      this.timeouts[0].splice(0, i);
      this.timeouts[1].splice(0, i);
    }
    let top = 0;
    for (const [follower, t] of this.traces) {
      if (t.tail(Math.min(this.known, now), from) === null) continue;
      if (present !== null && !present.has(follower)) continue;
      for (let i = t.ys.length - 1; i >= 0 && t.xs[i] >= from; i--) {
        if (t.ys[i] > top) top = t.ys[i];
      }
    }
    // The y range grows at once and shrinks slowly (no jumping axis).
    this.yMax = top > this.yMax ? top * 1.1 : Math.max(top * 1.1, this.yMax * 0.995);
    this.plot.batch(() => {
      this.plot.setData(this.data, false);
      this.plot.setScale("x", {min: from, max: now});
      this.plot.setScale("y", {min: 0, max: Math.max(this.yMax, 1e-3)});
    });
  }
}
