// Experiment runs as they fill in (wiswarm/experiments/<run>/points): the study's two
// panels side by side, like its PNGs: (a) WiSwarm against the baselines at their fixed
// rate, (b) against the baselines at their best rate, a metric against N.

import {colour} from "./sawtooth.js";

const PANEL_WIDTH = 460;
const PANEL_HEIGHT = 260;
const LOG_METRICS = new Set(["mean_aoi_s", "p95_aoi_s"]);

function panels(run) {
  const fixed = `@${Number(run.fixed_rate)}`;
  return [
    ["(a) fixed rate", [...run.baselines.map((b) => b + fixed), "wiswarm"]],
    ["(b) optimised rate", [...run.baselines.map((b) => `${b}-opt`), "wiswarm"]],
  ];
}

function aligned(points, labels, metric) {
  // uPlot's data: the Ns, then per label its value at each N (null: not measured yet).
  const ns = [...new Set(points.map((p) => p.n))].sort((a, b) => a - b);
  const value = new Map(points.map((p) => [`${p.label} ${p.n}`, p.mean[metric]]));
  return [ns, ...labels.map((label) => ns.map((n) => {
    const v = value.get(`${label} ${n}`);
    return v === undefined || v === null || (LOG_METRICS.has(metric) && v <= 0) ? null : v;
  }))];
}

export class Experiments {
  constructor(element, select) {
    this.element = element;
    this.select = select;
    this.runs = new Map();  // run -> {record, plots, box}
    select.addEventListener("change", () => {
      for (const run of this.runs.values()) this.rebuild(run);
    });
  }

  reset(records) {
    for (const run of this.runs.values()) run.box.remove();
    this.runs.clear();
    for (const record of records) this.set(record);
  }

  set(record) {
    let run = this.runs.get(record.run);
    if (run === undefined) {
      const box = document.createElement("div");
      box.className = "run";
      box.dataset.run = record.run;
      const title = document.createElement("h3");
      const holder = document.createElement("div");
      holder.className = "panels";
      box.append(title, holder);
      this.element.prepend(box);  // the newest run first
      run = {record, plots: [], box, title, holder};
      this.runs.set(record.run, run);
      this.element.parentElement.hidden = false;
    }
    run.record = record;
    run.title.textContent = `${record.run} (${record.study}, ${record.points.length} points` +
                            `${record.done ? ", done" : ", running"})`;
    if (run.plots.length === 0) this.rebuild(run);
    else this.update(run);
  }

  rebuild(run) {
    for (const plot of run.plots) plot.destroy();
    run.holder.replaceChildren();
    const metric = this.select.value;
    const label = this.select.selectedOptions[0].textContent;
    run.plots = panels(run.record).map(([title, labels]) => {
      const panel = document.createElement("div");
      panel.className = "panel";
      const heading = document.createElement("div");
      heading.className = "panel-title";
      heading.textContent = title;
      panel.append(heading);
      run.holder.append(panel);
      return new uPlot({
        width: PANEL_WIDTH, height: PANEL_HEIGHT, legend: {live: false},
        scales: {x: {time: false}, y: LOG_METRICS.has(metric) ? {distr: 3} : {}},
        axes: [{label: "number of UAVs N"}, {label, size: 60}],
        series: [{label: "N"}, ...labels.map((name) => ({
          label: name, stroke: name === "wiswarm" ? "#1f5fbf" : colour(labels.indexOf(name) + 3),
          width: 2, points: {show: true, size: 6}, spanGaps: true,
        }))],
      }, aligned(run.record.points, labels, metric), panel);
    });
  }

  update(run) {
    const metric = this.select.value;
    panels(run.record).forEach(([, labels], i) => {
      run.plots[i].setData(aligned(run.record.points, labels, metric));
    });
  }
}
