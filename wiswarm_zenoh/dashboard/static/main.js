// The live page: one WebSocket to the dashboard (a snapshot, then every change), drawn
// every animation frame. Times of deliveries are the leader's clock; the page keeps an
// estimate of it (the latest delivery time heard, against the page's own clock), so
// the sawtooth's right edge is the leader's "now" even if the clocks differ. Once the
// dashboard says its swarm is finished (a run that ended, kept on view), the right edge
// stays at the last delivery heard and the map does not fade: the run's end, as it was.
//
// For tests and benchmarks the page exposes ``window.wiswarm``: frames drawn and
// frames/s, connections made, and when the last delivery batch was drawn.

import {ArenaMap} from "./map.js";
import {Experiments} from "./experiments.js";
import {Sawtooth} from "./sawtooth.js";
import {FollowerTable} from "./table.js";

const TABLE_PERIOD_S = 0.25;
const OFFSET_SPAN_S = 10;  // the clock estimate takes the latest delivery of this long
const RETRY_S = [0.25, 0.5, 1, 2];  // reconnection back-off
const LATENCIES_KEPT = 500;

const $ = (id) => document.getElementById(id);
const pageNow = () => Date.now() / 1000;

const live = {
  frames: 0, fps: 0, connects: 0, socket: null,
  lastDelivery: null,  // {delivered_at, oldest_delivered_at, drawn_at} of the last batch drawn
  latencies: [],  // per batch drawn: drawn_at - its oldest delivered_at (seconds): the worst
  newestLatencies: [],  // and drawn_at - its newest: what the page itself adds
};
window.wiswarm = live;

const sawtooth = new Sawtooth($("sawtooth"), 30, onDrawn);
const table = new FollowerTable(document.querySelector("#followers tbody"));
const map = new ArenaMap($("map"), (uav) => colourOf(uav));
const experiments = new Experiments($("experiments"), $("metric"));
let leader = null;  // the latest leader stats
let status = null;  // the latest status message
let finishedPage = null;  // page time when the dashboard was first heard finished
let offsets = [];  // [page time, delivered_at - page time] of recent batches
let serverOffset = 0;  // the dashboard's clock minus the page's
let pending = null;  // deliveries received, not drawn yet
let tableAt = 0;
let fpsMark = [pageNow(), 0];

function colourOf(follower) {
  return sawtooth.trace(follower).colour;  // the same in the chart, the table and the map
}

function leaderNow() {
  const now = pageNow();
  const since = now - OFFSET_SPAN_S;
  offsets = offsets.filter(([at]) => at >= since);
  if (offsets.length === 0) return now + serverOffset;
  return now + Math.max(...offsets.map(([, offset]) => offset));
}

function onDrawn() {
  live.frames++;
  if (pending !== null) {
    const drawn = pageNow();
    live.lastDelivery = {...pending, drawn_at: drawn};
    live.latencies.push(drawn - pending.oldest_delivered_at);
    live.newestLatencies.push(drawn - pending.delivered_at);
    if (live.latencies.length > LATENCIES_KEPT) live.latencies.shift();
    if (live.newestLatencies.length > LATENCIES_KEPT) live.newestLatencies.shift();
    pending = null;
  }
}

function onDeliveries(records) {
  if (records.length === 0) return;
  sawtooth.add(records);
  let newest = -Infinity;
  let oldest = Infinity;
  for (const [, , delivered] of records) {
    if (delivered > newest) newest = delivered;
    if (delivered < oldest) oldest = delivered;
  }
  const now = pageNow();
  offsets.push([now, newest - now]);
  pending = {
    delivered_at: newest,
    oldest_delivered_at: Math.min(oldest, pending === null ? oldest : pending.oldest_delivered_at),
  };
}

function onSnapshot(snapshot) {
  $("swarm").textContent = snapshot.swarm;
  $("window").textContent = snapshot.window_s;
  sawtooth.windowS = snapshot.window_s;
  sawtooth.reset(snapshot.traces);
  table.reset(snapshot.stats);
  leader = snapshot.leader;
  offsets = [];
  finishedPage = null;
  map.reset(snapshot.tracking, pageNow());
  experiments.reset(snapshot.runs);
  onStatus(snapshot.status);
}

function onStatus(message) {
  status = message;
  serverOffset = message.now - pageNow();
  if (finished() && finishedPage === null) finishedPage = pageNow();
  const bad = $("bad-input");
  bad.hidden = message.bad_input === 0;
  bad.textContent = `${message.bad_input} bad messages skipped (see the dashboard's log)`;
  showLeader();
}

function clock(seconds) {
  return new Date(seconds * 1000).toLocaleTimeString();
}

function finished() {
  return status !== null && status.finished_at != null;
}

function showLeader() {
  const element = $("leader");
  if (status === null) return;
  if (finished()) {
    element.textContent = `finished at ${clock(status.finished_at)}: the run's last ` +
      "state, no longer live";
    element.classList.remove("alarm");
    return;
  }
  if (!status.leader_alive) {
    const since = status.leader_seen_at === null ? status.started_at : status.leader_seen_at;
    element.textContent = `no leader since ${clock(since)}`;
    element.classList.add("alarm");
    return;
  }
  element.classList.remove("alarm");
  if (leader === null) return;
  // the epoch is the time (us since 1970) the leader took its role: shown as that time
  const since = leader.epoch ? new Date(leader.epoch / 1000).toISOString().replace("T", " ")
    .slice(0, 19) + " UTC" : "";
  const name = leader.leader ? `leader ${leader.leader}, active since ${since}` : "leader";
  element.textContent = `${name} · ${leader.policy} · ${leader.followers.length} followers` +
    ` · ${(leader.polls_per_s || 0).toFixed(0)} polls/s · up ${(leader.uptime_s || 0).toFixed(0)} s`;
}

const HANDLERS = {
  snapshot: onSnapshot,
  deliveries: (m) => onDeliveries(m.records),
  stats: (m) => table.set(m.record),
  leader: (m) => { leader = m.record; showLeader(); },
  tracking: (m) => map.set(m.record, pageNow()),
  run: (m) => experiments.set(m.record),
  status: onStatus,
};

function connect(attempt = 0) {
  const url = `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`;
  const socket = new WebSocket(url);
  live.socket = socket;
  socket.onopen = () => {
    live.connects++;
    attempt = 0;
    $("connection").textContent = "";
    $("connection").className = "status quiet";
  };
  socket.onmessage = (event) => {
    for (const message of JSON.parse(event.data)) HANDLERS[message.type]?.(message);
  };
  socket.onclose = () => {
    $("connection").textContent = "dashboard connection lost, reconnecting\u2026";
    $("connection").className = "status alarm";
    setTimeout(() => connect(attempt + 1), 1000 * RETRY_S[Math.min(attempt, RETRY_S.length - 1)]);
  };
}

function frame() {
  const over = finished();
  const now = over && Number.isFinite(sawtooth.known) ? sawtooth.known : leaderNow();
  // finished: every follower counts (the UAVs left the leader as the run ended)
  const present = !over && status !== null && status.leader_alive && leader !== null
    ? new Set(leader.followers) : null;
  sawtooth.draw(now, present);
  const page = pageNow();
  if (page - tableAt >= TABLE_PERIOD_S) {
    tableAt = page;
    const names = new Set([...sawtooth.traces.keys(), ...table.stats.keys()]);
    table.render(names, (f) => sawtooth.age(f), colourOf, present);
    map.draw(finishedPage === null ? page : Math.min(page, finishedPage));
  }
  if (page - fpsMark[0] >= 1) {
    live.fps = (live.frames - fpsMark[1]) / (page - fpsMark[0]);
    fpsMark = [page, live.frames];
  }
  requestAnimationFrame(frame);
}

connect();
requestAnimationFrame(frame);
