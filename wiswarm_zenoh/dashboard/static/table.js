// The followers' table: the leader's stats per follower, with the age now taken from
// the delivery stream (exact, not the last stats' sample). Cells are written only
// when their text changes, a few times a second: a hundred rows stay cheap.

const COLUMNS = [
  ["aoi", (s, age) => ms(age)],
  ["mean", (s) => ms(s.mean_aoi_s)],
  ["p95", (s) => ms(s.p95_aoi_s)],
  ["p_hat", (s) => fixed(s.p_hat, 2)],
  ["weight", (s) => fixed(s.weight, 2)],
  ["polls", (s) => fixed(s.polls_per_s, 0)],
  ["timeouts", (s) => count(s.timeouts)],
  ["errors", (s) => count(s.errors)],
];

function ms(seconds) {
  return seconds === null || seconds === undefined ? "-" : (seconds * 1e3).toFixed(0);
}

function fixed(value, digits) {
  return value === null || value === undefined ? "-" : value.toFixed(digits);
}

function count(value) {
  return value === null || value === undefined ? "-" : String(value);
}

// A robot serving several streams has a member per stream, <robot>~<stream>: its rows
// go together, under the robot's name.
const STREAM = "~";

function robotOf(follower) {
  return follower.split(STREAM, 1)[0];
}

function byName(a, b) {
  const robots = robotOf(a).localeCompare(robotOf(b), undefined, {numeric: true});
  return robots !== 0 ? robots : a.localeCompare(b, undefined, {numeric: true});
}

export class FollowerTable {
  constructor(body) {
    this.body = body;
    this.stats = new Map();  // follower -> its latest stats record
    this.rows = new Map();  // follower -> {row, cells}
  }

  reset(records) {
    this.stats.clear();
    for (const record of records) this.stats.set(record.follower, record);
  }

  set(record) {
    this.stats.set(record.follower, record);
  }

  row(follower) {
    let entry = this.rows.get(follower);
    if (entry !== undefined) return entry;
    const row = document.createElement("tr");
    row.dataset.follower = follower;
    row.dataset.robot = robotOf(follower);
    const name = document.createElement("td");
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    const stream = follower.indexOf(STREAM);
    if (stream < 0) {
      name.append(swatch, follower);
    } else {  // the robot, then its stream a shade lighter
      const label = document.createElement("span");
      label.className = "stream";
      label.textContent = follower.slice(stream);
      name.append(swatch, follower.slice(0, stream), label);
      name.title = `stream ${follower.slice(stream + 1)} of robot ${follower.slice(0, stream)}`;
    }
    row.append(name);
    const cells = COLUMNS.map(() => row.appendChild(document.createElement("td")));
    entry = {row, cells, swatch};
    this.rows.set(follower, entry);
    const names = [...this.rows.keys()].sort(byName);
    const next = names[names.indexOf(follower) + 1];
    this.body.insertBefore(row, next === undefined ? null : this.rows.get(next).row);
    return entry;
  }

  render(followers, ageOf, colourOf, present) {
    // ``followers``: every name heard; ``present``: those the leader lists (null: any).
    for (const follower of followers) {
      const colour = colourOf(follower);
      const {row, cells, swatch} = this.row(follower);
      if (swatch.dataset.colour !== colour) {
        swatch.dataset.colour = colour;
        swatch.style.background = colour;
      }
      const stats = this.stats.get(follower) || {};
      const age = ageOf(follower);
      COLUMNS.forEach(([, text], i) => {
        const value = text(stats, age);
        if (cells[i].textContent !== value) cells[i].textContent = value;
      });
      row.classList.toggle("gone", present !== null && !present.has(follower));
    }
  }
}
