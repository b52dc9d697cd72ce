// photonfarm monitor: the queue's JSON (/api/...) as tables, a frame grid and stage bars,
// refreshed at every "update" event of /api/events. Every value from the queue is set as
// text (textContent, attributes), never parsed as HTML.
'use strict';

const stageColours = ['#4e79a7', '#f28e2b', '#e15759', '#76b7b2', '#59a14f', '#edc948',
  '#b07aa1', '#ff9da7', '#9c755f', '#bab0ac', '#86bcb6', '#d37295'];
// Frames named beside each stage's distribution: those above its p95, slowest first.
const OUTLIERS_SHOWN = 3;
let selectedJob = null;
let selectedFrame = null;

function selectFrame(frame) { selectedFrame = frame; refresh(); }

function el(tag, text, className) {
  const node = document.createElement(tag);
  if (text !== undefined && text !== null) node.textContent = String(text);
  if (className) node.className = className;
  return node;
}

function bytes(value) {
  if (!(value > 0)) return '-';
  if (value >= 2 ** 30) return (value / 2 ** 30).toFixed(1) + ' GiB';
  if (value >= 2 ** 20) return (value / 2 ** 20).toFixed(0) + ' MiB';
  return (value / 1024).toFixed(0) + ' KiB';
}

function duration(seconds) {
  if (seconds === null || seconds === undefined) return '-';
  if (seconds < 60) return seconds.toFixed(0) + ' s';
  if (seconds < 3600) return (seconds / 60).toFixed(1) + ' min';
  return (seconds / 3600).toFixed(1) + ' h';
}

// The server's clock, from its responses' Date header: ages and ETAs are measured on it.
let serverOffsetMs = 0;

async function getJson(path) {
  const response = await fetch(path, {cache: 'no-store'});
  if (!response.ok) throw new Error(path + ': ' + response.status);
  const date = Date.parse(response.headers.get('Date') || '');
  if (!Number.isNaN(date)) serverOffsetMs = date - Date.now();
  return response.json();
}

function serverNow() { return Date.now() + serverOffsetMs; }

// From the job's pace so far: frames done over the time since it was enqueued.
function eta(job) {
  const left = job.frames_total - job.frames_done;
  const elapsed = (serverNow() - job.created_at) / 1000;
  if (job.frames_done <= 0 || left <= 0 || elapsed <= 0 ||
      !['running', 'queued'].includes(job.status)) return null;
  return elapsed / job.frames_done * left;
}

function jobName(job) {
  return (job.parameters && typeof job.parameters.name === 'string') ? job.parameters.name : '';
}

function renderJobs(jobs) {
  const body = document.querySelector('#jobs tbody');
  body.replaceChildren();
  for (const job of jobs) {
    const row = el('tr', null, 'job' + (job.id === selectedJob ? ' selected' : ''));
    row.dataset.job = job.id;
    const progress = el('progress');
    progress.max = Math.max(job.frames_total, 1);
    progress.value = job.frames_done;
    // The preset: what auto chose for the highest finished frame, and why (its plan row).
    const quality = job.parameters ? job.parameters.quality : '';
    const colon = job.plan.indexOf(':');
    const preset = job.plan ? (colon >= 0 ? job.plan.slice(0, colon) : job.plan) : quality;
    const why = colon >= 0 ? job.plan.slice(colon + 1).trim()
      : quality === 'auto' ? 'chosen at its first frame' : quality ? 'as enqueued' : '';
    const cells = [job.id, jobName(job), null, null, job.frames_done + '/' + job.frames_total,
      job.tasks.running, job.tasks.failed, job.priority, preset, duration(eta(job)), job.note];
    cells.forEach((value, index) => {
      const cell = el('td', value);
      if (index === 2) { cell.textContent = job.status; cell.className = 'state-' + job.status; }
      if (index === 3) cell.append(progress);
      if (index === 8 && why) {
        cell.className = 'preset';
        cell.append(el('div', why, 'why'));
      }
      if (index === 10) cell.className = 'note';
      row.append(cell);
    });
    row.addEventListener('click', () => { selectedJob = job.id; selectedFrame = null; refresh(); });
    body.append(row);
  }
}

function renderWorkers(workers, stats) {
  const body = document.querySelector('#workers tbody');
  body.replaceChildren();
  const statsOf = {};
  for (const entry of stats) statsOf[entry.id] = entry;
  for (const worker of workers) {
    const done = statsOf[worker.id] || {frames_done: '-', failures: '-', blocked_jobs: ''};
    const state = worker.stopped ? 'stopped' : (worker.alive ? 'alive' : 'dead');
    const doing = worker.job === null ? 'idle' : 'job ' + worker.job + ' frame ' + worker.frame;
    const row = el('tr');
    for (const value of [worker.name, state,
      duration(Math.max(0, (serverNow() - worker.heartbeat_at) / 1000)) + ' ago',
      worker.device, worker.device_type, bytes(worker.device_memory), bytes(worker.host_memory),
      worker.cores || '-', worker.tags, doing, done.frames_done, done.failures,
      done.blocked_jobs || '-']) row.append(el('td', value));
    row.children[1].className = worker.alive ? 'state-running' : 'state-failed';
    body.append(row);
  }
}

// The selected frame: its failures and what each attempt at it logged on its worker.
function renderFrame(job, frameLog) {
  const detail = document.getElementById('frame-detail');
  detail.hidden = frameLog === null;
  if (frameLog === null) return;
  document.getElementById('frame-title').textContent = 'Frame ' + frameLog.frame;
  const failures = document.getElementById('frame-failures');
  failures.replaceChildren();
  for (const failure of job.failures.filter((f) => f.frame === frameLog.frame))
    failures.append(el('li', 'attempt ' + failure.attempt + ' on ' + failure.worker + ' failed: ' +
      failure.error));
  const logs = document.getElementById('frame-logs');
  logs.replaceChildren();
  if (frameLog.attempts.length === 0)
    logs.append(el('p', 'No log stored: not rendered yet, or its worker was killed.'));
  for (const attempt of frameLog.attempts) {
    logs.append(el('h4', 'attempt ' + attempt.attempt + ' on ' + (attempt.worker || 'an unknown worker') +
      ' (frames ' + attempt.first_frame + '-' + attempt.last_frame + '), ' +
      new Date(attempt.written_at).toLocaleString()));
    logs.append(el('pre', attempt.log, 'log'));
  }
}

function renderDetail(job, timings, frames, frameLog) {
  document.getElementById('detail').hidden = false;
  document.getElementById('detail-title').textContent =
    'Job ' + job.id + (jobName(job) ? ' (' + jobName(job) + ')' : '');
  const plan = timings.decisions.find((d) => d.stage === 'plan');
  document.getElementById('detail-summary').textContent =
    job.status + ', ' + job.frames_done + '/' + job.frames_total + ' frames, scene ' + job.scene +
    ' -> ' + job.output + (plan ? ', preset: ' + plan.decision : '') +
    (job.requires ? ', requires ' + job.requires : '') +
    (job.prerequisites ? ', after job ' + job.prerequisites : '') +
    (job.note ? ' - ' + job.note : '');

  // status's advice for a job whose frames ran out of memory.
  const advice = document.getElementById('memory-advice');
  const memory = job.memory_advice;
  advice.hidden = !memory;
  if (memory) {
    const failures = job.memory_failures + ' failure' + (job.memory_failures === 1 ? '' : 's') +
      ' ran out of memory';
    const flags = (memory.min_memory ? ' --min-memory ' + memory.min_memory : '') +
      (memory.min_device_memory ? ' --min-device-memory ' + memory.min_device_memory : '');
    advice.textContent = 'memory: ' + failures + (flags
      ? '; its finished frames peaked at ' + bytes(memory.peak_rss) + ' of memory and ' +
        bytes(memory.peak_device_memory) + ' of device memory. Suggestion: enqueue it again with' +
        flags + ' (' + memory.headroom_percent + '% over those peaks), so that smaller workers ' +
        'do not claim it'
      : '; no frame of it has finished to measure');
  }

  const grid = document.getElementById('frame-grid');
  grid.replaceChildren();
  for (const task of job.task_list) {
    const holds = selectedFrame !== null && task.first_frame <= selectedFrame &&
      selectedFrame <= task.last_frame;
    const cell = el('span', null, 'cell ' + task.status + (holds ? ' selected' : ''));
    cell.addEventListener('click', () => selectFrame(task.first_frame));
    cell.title = 'frame ' + task.first_frame +
      (task.last_frame !== task.first_frame ? '-' + task.last_frame : '') + ': ' + task.status +
      (task.worker ? ' on ' + task.worker : '') + (task.last_error ? ' - ' + task.last_error : '');
    cell.dataset.status = task.status;
    grid.append(cell);
  }

  // Per stage: the distribution over frames as a chart on one log scale for every stage
  // (min to max, median to p95), and the frame behind the slowest, which opens its log.
  const stageBody = document.querySelector('#stages tbody');
  stageBody.replaceChildren();
  const colour = {};
  timings.stages.forEach((stage, index) => { colour[stage.stage] = stageColours[index % stageColours.length]; });
  const ran = timings.stages.filter((stage) => stage.wall.count > 0);
  const low = Math.max(0.01, Math.min(...ran.map((stage) => stage.wall.min_ms), 1e9));
  const high = Math.max(low * 10, ...ran.map((stage) => stage.wall.max_ms));
  const x = (ms) => (200 * Math.log(Math.max(ms, low) / low) / Math.log(high / low));
  for (const stage of timings.stages) {
    // Its outliers: the frames above p95 (the slowest when none is), slowest first.
    const runs = [];
    for (const frame of frames.frames)
      for (const row of frame.stages)
        if (row.stage === stage.stage && !row.skipped) runs.push({frame: frame.frame, ms: row.wall_ms});
    runs.sort((a, b) => b.ms - a.ms);
    const above = runs.filter((r) => r.ms > stage.wall.p95_ms);
    const outliers = (above.length ? above : runs).slice(0, OUTLIERS_SHOWN);
    const row = el('tr');
    const w = stage.wall;
    for (const value of [stage.stage, stage.count, stage.skipped, w.min_ms.toFixed(2),
      w.median_ms.toFixed(2), w.p95_ms.toFixed(2), w.max_ms.toFixed(2)])
      row.append(el('td', value));
    const chart = el('span', null, 'dist');
    chart.dataset.stage = stage.stage;
    if (w.count > 0) {
      chart.title = stage.stage + ': min ' + w.min_ms.toFixed(2) + ', median ' +
        w.median_ms.toFixed(2) + ', p95 ' + w.p95_ms.toFixed(2) + ', max ' + w.max_ms.toFixed(2) + ' ms';
      const whisker = el('i', null, 'whisker');
      whisker.style.left = x(w.min_ms).toFixed(1) + 'px';
      whisker.style.width = Math.max(1, x(w.max_ms) - x(w.min_ms)).toFixed(1) + 'px';
      const box = el('i', null, 'box');
      box.style.left = x(w.median_ms).toFixed(1) + 'px';
      box.style.width = (x(w.p95_ms) - x(w.median_ms)).toFixed(1) + 'px';
      box.style.background = colour[stage.stage];
      const median = el('i', null, 'median');
      median.style.left = x(w.median_ms).toFixed(1) + 'px';
      chart.append(whisker, box, median);
      for (const outlier of outliers) {
        const dot = el('i', null, 'outlier');
        dot.style.left = (x(outlier.ms) - 2).toFixed(1) + 'px';
        dot.title = 'frame ' + outlier.frame + ': ' + outlier.ms.toFixed(2) + ' ms';
        chart.append(dot);
      }
    }
    const chartCell = el('td');
    chartCell.append(chart);
    row.append(chartCell);
    const slowestCell = el('td');
    for (const outlier of outliers) {
      const link = el('button', outlier.frame, 'frame-link');
      link.title = outlier.ms.toFixed(2) + ' ms: show frame ' + outlier.frame;
      link.addEventListener('click', () => selectFrame(outlier.frame));
      slowestCell.append(link, ' ');
    }
    if (!outliers.length) slowestCell.textContent = '-';
    row.append(slowestCell);
    stageBody.append(row);
  }
  const legend = document.getElementById('legend');
  legend.replaceChildren();
  for (const stage of timings.stages) {
    const item = el('span', stage.stage);
    const swatch = el('i');
    swatch.style.background = colour[stage.stage];
    item.prepend(swatch);
    legend.append(item);
  }
  // Each frame's stages as a stacked bar, one colour per stage; skipped stages take no room.
  const bars = document.getElementById('frame-bars');
  bars.replaceChildren();
  const longest = Math.max(1, ...frames.frames.map((f) => f.wall_ms));
  for (const frame of frames.frames) {
    const row = el('div', null, 'row');
    row.addEventListener('click', () => selectFrame(frame.frame));
    row.append(el('span', frame.frame, 'label'));
    const bar = el('span', null, 'bar');
    bar.dataset.frame = frame.frame;
    for (const stage of frame.stages) {
      if (stage.skipped && !stage.reused) continue;
      const part = el('i', null, stage.reused ? 'reused' : null);
      if (!stage.reused) part.style.width = (400 * stage.wall_ms / longest).toFixed(1) + 'px';
      part.style.background = colour[stage.stage] || '#999';
      part.title = stage.stage + ': ' + stage.wall_ms.toFixed(1) + ' ms' +
        (stage.decision ? ' (' + stage.decision + ')' : '');
      part.dataset.stage = stage.stage;
      bar.append(part);
    }
    row.append(bar, el('span', frame.wall_ms.toFixed(0) + ' ms, ' + bytes(frame.peak_rss_bytes) +
      ' peak, ' + (frame.worker || '-'), 'label wide'));
    bars.append(row);
  }

  // What `timings` adds: each frame's peaks and bytes, totals, builds and decisions.
  const perFrame = document.querySelector('#per-frame tbody');
  perFrame.replaceChildren();
  for (const [label, key] of [['peak memory', 'peak_rss'], ['peak device memory', 'peak_device_memory'],
    ['written', 'bytes_written']]) {
    const stat = timings.per_frame_bytes[key];
    const row = el('tr');
    for (const value of [label, stat.frames, bytes(stat.min), bytes(stat.median), bytes(stat.p95),
      bytes(stat.max)]) row.append(el('td', value));
    perFrame.append(row);
  }
  document.getElementById('totals').textContent = 'total: wall ' +
    timings.total_wall_ms.toFixed(0) + ' ms, gpu ' + timings.total_gpu_ms.toFixed(0) + ' ms' +
    (timings.builds.length ? '; rendered by ' + timings.builds.map((b) =>
      'photonfarm ' + b.build + ' (' + b.frames + ')').join(', ') : '');
  const decisions = document.querySelector('#decisions tbody');
  decisions.replaceChildren();
  for (const decision of timings.decisions) {
    const row = el('tr');
    for (const value of [decision.stage, decision.decision, decision.count]) row.append(el('td', value));
    const share = el('span', null, 'share');
    share.style.width = (150 * decision.count / Math.max(1, frames.count)).toFixed(1) + 'px';
    share.style.background = colour[decision.stage] || '#999';
    const shareCell = el('td');
    shareCell.append(share);
    row.append(shareCell);
    decisions.append(row);
  }
  // What `status` adds: the running frames, their workers and their leases.
  const running = document.getElementById('running');
  running.replaceChildren();
  for (const task of job.task_list.filter((t) => t.status === 'running'))
    running.append(el('li', 'frame ' + task.first_frame +
      (task.last_frame !== task.first_frame ? '-' + task.last_frame : '') + ' on ' + task.worker +
      ' (attempt ' + task.attempt + ', lease ' +
      Math.max(0, (task.lease_expires - serverNow()) / 1000).toFixed(1) + ' s left)'));

  // The latest finished frame, fetched again at each update (the server caches it).
  const image = document.getElementById('last-frame');
  const exposure = document.getElementById('exposure').value;
  image.onload = () => { image.hidden = false; };
  image.onerror = () => { image.hidden = true; };
  image.src = '/api/jobs/' + job.id + '/last.png?exposure=' + encodeURIComponent(exposure) +
    '&done=' + job.frames_done;

  renderFrame(job, frameLog);

  const failures = document.getElementById('failures');
  failures.replaceChildren();
  for (const failure of job.failures.slice(-50))
    failures.append(el('li', 'frame ' + failure.frame + ' attempt ' + failure.attempt + ' on ' +
      failure.worker + ': ' + failure.error));
}

async function refresh() {
  try {
    const [jobs, workers, stats] = await Promise.all(
      [getJson('/api/jobs'), getJson('/api/workers'), getJson('/api/workers/stats')]);
    renderJobs(jobs);
    renderWorkers(workers, stats);
    if (selectedJob !== null) {
      const base = '/api/jobs/' + selectedJob;
      const [job, timings, frames, frameLog] = await Promise.all(
        [getJson(base), getJson(base + '/timings'), getJson(base + '/frames'),
          selectedFrame === null ? null : getJson(base + '/frames/' + selectedFrame + '/log')]);
      renderDetail(job, timings, frames, frameLog);
    }
    document.getElementById('updated').textContent = 'updated ' + new Date().toLocaleTimeString();
  } catch (error) {
    document.getElementById('updated').textContent = String(error);
  }
}

async function act(action) {
  const result = document.getElementById('action-result');
  const value = action === 'priority' ?
    '?value=' + encodeURIComponent(document.getElementById('priority').value) : '';
  const response = await fetch('/api/jobs/' + selectedJob + '/' + action + value, {
    method: 'POST', headers: {'X-Photonfarm-Token': document.getElementById('token').value}});
  const body = await response.json().catch(() => ({}));
  result.textContent = response.ok ? action + ': done' : (body.error || response.status);
}

function connect() {
  const live = document.getElementById('live');
  const events = new EventSource('/api/events');
  events.addEventListener('update', () => { live.textContent = 'live'; live.className = 'live on'; refresh(); });
  events.onerror = () => { live.textContent = 'reconnecting'; live.className = 'live off'; };
}

document.getElementById('exposure').addEventListener('change', (event) => {
  document.getElementById('exposure-value').textContent = event.target.value + ' EV';
  refresh();
});
document.querySelectorAll('#actions button').forEach((button) =>
  button.addEventListener('click', () => act(button.dataset.action)));
const params = new URLSearchParams(location.search);
if (params.has('job')) selectedJob = Number(params.get('job'));
if (params.has('frame')) selectedFrame = Number(params.get('frame'));
connect();
