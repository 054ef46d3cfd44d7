// The es2particles executor of a WebGL 1 page: runs the plan that es2particles/export.py wrote
// into this page (state textures, passes, points, post stages) with the same GLSL ES 1.00
// sources the EGL run compiles. No network: everything it needs is in the page.
//
// window.es2particles is its interface for tests and the console: step(n), state(name, part),
// density(), image(), and what the context offers (facts).
"use strict";
(function () {
  const plan = JSON.parse(document.getElementById("es2particles-plan").textContent);
  const params = new URLSearchParams(window.location.search);
  const facts = {};

  function fail(message) {
    const box = document.getElementById("problems");
    box.hidden = false;
    box.textContent += message + "\n";
    window.es2particles = { error: message, facts };
    throw new Error(message);
  }

  function show(name, value) {
    facts[name] = value;
    const list = document.getElementById("facts");
    let row = list.querySelector(`[data-fact="${name}"]`);
    if (!row) {
      const term = document.createElement("dt");
      term.textContent = name;
      row = document.createElement("dd");
      row.dataset.fact = name;
      list.append(term, row);
    }
    row.textContent = String(value);
  }

  // -- the context, and what the ES 2.0 article requires of it ---------------------------------
  const [width, height] = plan.size;
  const canvas = document.getElementById("view");
  canvas.width = width;
  canvas.height = height;
  const gl = canvas.getContext("webgl", {
    alpha: false, antialias: false, depth: false, stencil: false,
    premultipliedAlpha: false, preserveDrawingBuffer: true,
  });
  if (!gl) fail("This browser gives no WebGL 1 context.");
  const debug = gl.getExtension("WEBGL_debug_renderer_info");
  show("renderer", debug ? gl.getParameter(debug.UNMASKED_RENDERER_WEBGL)
                         : gl.getParameter(gl.RENDERER));
  show("version", gl.getParameter(gl.VERSION));
  const vertexUnits = gl.getParameter(gl.MAX_VERTEX_TEXTURE_IMAGE_UNITS);
  const highp = gl.getShaderPrecisionFormat(gl.FRAGMENT_SHADER, gl.HIGH_FLOAT).precision;
  const maxTexture = gl.getParameter(gl.MAX_TEXTURE_SIZE);
  const pointSizes = gl.getParameter(gl.ALIASED_POINT_SIZE_RANGE);
  show("vertex texture units", vertexUnits);
  show("fragment highp", highp > 0 ? `yes (${highp}-bit significand)` : "no");
  const missing = [];
  if (vertexUnits < 1) {
    missing.push("vertex texture fetch: MAX_VERTEX_TEXTURE_IMAGE_UNITS is 0, so the vertex " +
                 "shader cannot read the particles' positions");
  }
  if (highp < 1) {
    missing.push("highp float in fragment shaders: the 16-bit packed state and the passes' " +
                 "arithmetic need it");
  }
  const side = Math.max(plan.layout.width, plan.layout.height, width, height);
  if (side > maxTexture) {
    missing.push(`textures ${side} texels wide: this context's limit is ${maxTexture}`);
  }
  const pointSize = plan.points.uniforms.u_point_size[0];
  if (pointSize > pointSizes[1]) {
    missing.push(`points of ${pointSize} pixels: this context's largest is ${pointSizes[1]}`);
  }
  const floatTextures = Object.values(plan.textures).some((t) => t.type === "float");
  if (floatTextures && !gl.getExtension("OES_texture_float")) {
    missing.push("OES_texture_float: the scene samples float textures");
  }
  if (missing.length) {
    fail("This context lacks what the scene needs (the ES 2.0 article's requirements):\n- " +
         missing.join("\n- "));
  }

  // -- textures and framebuffers: made once ----------------------------------------------------
  function texture(w, h, type, linear, data) {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    const filter = linear ? gl.LINEAR : gl.NEAREST;  // packed state is never filtered
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, filter);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, filter);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, w, h, 0, gl.RGBA, type, data || null);
    return { texture: t, width: w, height: h, type, framebuffer: null };
  }

  function target(t) {
    t.framebuffer = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.framebuffer);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, t.texture, 0);
    const complete = gl.checkFramebufferStatus(gl.FRAMEBUFFER) === gl.FRAMEBUFFER_COMPLETE;
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    return complete ? t : null;
  }

  function bytes(base64) {
    const text = atob(base64);
    const out = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i += 1) out[i] = text.charCodeAt(i);
    return out;
  }

  function base64(view) {
    const raw = new Uint8Array(view.buffer, view.byteOffset, view.byteLength);
    let text = "";
    for (let i = 0; i < raw.length; i += 0x8000) {
      text += String.fromCharCode.apply(null, raw.subarray(i, i + 0x8000));
    }
    return btoa(text);
  }

  // -- the density path: the first the context offers, or the one the address asks for --------
  function renders(type) {  // a small target of this type, made and deleted again
    const probe = texture(4, 4, type, false);
    const complete = target(probe) !== null;
    gl.deleteFramebuffer(probe.framebuffer);
    gl.deleteTexture(probe.texture);
    return complete;
  }

  const halfFloat = gl.getExtension("OES_texture_half_float");
  const offers = {
    float: () => gl.getExtension("OES_texture_float") &&
                 gl.getExtension("WEBGL_color_buffer_float") &&
                 gl.getExtension("EXT_float_blend") && renders(gl.FLOAT),
    half: () => halfFloat && gl.getExtension("EXT_color_buffer_half_float") &&
                renders(halfFloat.HALF_FLOAT_OES),
    bytes: () => true,
  };
  const HOW = {
    float: "float: additive points into RGBA32F (WEBGL_color_buffer_float, EXT_float_blend)",
    half: "half: batches of points into RGBA16F (EXT_color_buffer_half_float), added to an " +
          "exact count in RGBA8",
    bytes: "bytes: batches of points into RGBA8, a quarter of each per channel, added to an " +
           "exact count in RGBA8 (no extension)",
  };
  const asked = params.get("density");
  if (asked !== null && !plan.density.paths.includes(asked)) {
    fail(`density=${asked}: the paths are ${plan.density.paths.join(", ")}`);
  }
  const path = (asked !== null ? [asked] : plan.density.paths).find((name) => offers[name]());
  if (path === undefined) fail(`density=${asked}: this context does not offer it`);
  show("density", HOW[path] + (asked !== null ? " (asked for)" : ""));
  // A hit adds `levels` codes (fading points fewer); a code is 1/255 of a byte or 1.0 of a half.
  const levels = plan.points.fade && path !== "float" ? plan.density.fade_levels[path] : 1;
  const code = path === "bytes" ? 1 / 255 : 1;

  // -- programs --------------------------------------------------------------------------------
  const SIZES = { [gl.FLOAT]: 1, [gl.FLOAT_VEC2]: 2, [gl.FLOAT_VEC3]: 3, [gl.FLOAT_VEC4]: 4 };
  const SETTERS = { 1: "uniform1fv", 2: "uniform2fv", 3: "uniform3fv", 4: "uniform4fv" };

  function shader(kind, source, name, file) {
    const s = gl.createShader(kind);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) {
      fail(`${name}: ${file} does not compile here:\n${gl.getShaderInfoLog(s)}`);
    }
    return s;
  }

  const programs = plan.programs.map((p) => {
    const program = gl.createProgram();
    gl.attachShader(program, shader(gl.VERTEX_SHADER, p.vertex, p.name, p.files[0]));
    gl.attachShader(program, shader(gl.FRAGMENT_SHADER, p.fragment, p.name, p.files[1]));
    gl.bindAttribLocation(program, 0, "a_position");  // each program has one attribute
    gl.bindAttribLocation(program, 0, "a_texel");
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) {
      fail(`${p.name}: linking failed:\n${gl.getProgramInfoLog(program)}`);
    }
    const uniforms = {};
    for (let i = 0; i < gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS); i += 1) {
      const info = gl.getActiveUniform(program, i);
      uniforms[info.name.replace(/\[0\]$/, "")] = {
        location: gl.getUniformLocation(program, info.name), type: info.type, size: info.size,
      };
    }
    const samplers = Object.keys(uniforms).filter((n) => uniforms[n].type === gl.SAMPLER_2D);
    samplers.sort();
    gl.useProgram(program);
    samplers.forEach((name, unit) => gl.uniform1i(uniforms[name].location, unit));
    return { program, name: p.name, uniforms, samplers };
  });

  // Uniforms by name, as flat lists of floats. One the driver dropped (its result unused) is not
  // active, and skipped; the EGL run checks that every name is declared and used.
  function use(p, values, textures) {
    gl.useProgram(p.program);
    for (const [name, value] of Object.entries(values)) {
      const u = p.uniforms[name];
      if (u === undefined) continue;
      const size = SIZES[u.type];
      gl[SETTERS[size]](u.location, new Float32Array(value.slice(0, size * u.size)));
    }
    p.samplers.forEach((name, unit) => {
      const t = textures[name];
      if (t === undefined) fail(`${p.name}: sampler ${name} is used but nothing feeds it`);
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, t.texture);
    });
  }

  const triangle = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, triangle);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
  // Each particle's texel centre, row by row: the vertex shader's index (ES 1.00 has no
  // gl_VertexID). Rounded to float32 as numpy's Layout.texel_uv rounds it.
  const L = plan.layout;
  const texels = new Float32Array(2 * L.count);
  for (let i = 0; i < L.count; i += 1) {
    texels[2 * i] = ((i % L.width) + 0.5) / L.width;
    texels[2 * i + 1] = (Math.floor(i / L.width) + 0.5) / L.height;
  }
  const texelBuffer = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, texelBuffer);
  gl.bufferData(gl.ARRAY_BUFFER, texels, gl.STATIC_DRAW);

  function attribute(buffer) {
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 0, 0);
  }

  function fullscreen(t) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, t === null ? null : t.framebuffer);
    gl.viewport(0, 0, t === null ? width : t.width, t === null ? height : t.height);
    attribute(triangle);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  function made(t, what) {
    if (t === null) fail(`${what}: the context cannot render into it`);
    return t;
  }

  // -- state: each part of each quantity, twice where last step's value is read ----------------
  const state = {};
  for (const [name, q] of Object.entries(plan.quantities)) {
    const parts = q.parts !== undefined ? q.parts.map(bytes) : q.clear.map((texel) => {
      const data = new Uint8Array(4 * L.width * L.height);
      for (let i = 0; i < data.length; i += 4) data.set(texel, i);
      return data;
    });
    state[name] = parts.map((data, part) => Array.from({ length: q.buffers }, () =>
      made(target(texture(L.width, L.height, gl.UNSIGNED_BYTE, false, data)),
           `state ${name} part ${part + 1}`)));
  }
  const sceneTextures = {};
  for (const [name, t] of Object.entries(plan.textures)) {
    const data = bytes(t.data);
    sceneTextures[name] = t.type === "float"
      ? texture(t.width, t.height, gl.FLOAT, false, new Float32Array(data.buffer))
      : texture(t.width, t.height, gl.UNSIGNED_BYTE, false, data);
  }
  const fixed = {};
  for (const [name, t] of Object.entries(plan.fixed)) {
    fixed[name] = texture(t.width, t.height, gl.UNSIGNED_BYTE, true, bytes(t.data));
  }

  // -- one step: every pass in the plan's order, then the ping-pong swap -----------------------
  const live = {};  // uniform -> values the sliders set
  let stepsDone = 0;

  function step() {
    for (const pass of plan.passes) {
      const textures = {};
      for (const [sampler, input] of Object.entries(pass.inputs)) {
        if (input[0] === "quantity") {
          const pair = state[input[1]][input[2]];
          textures[sampler] = input[3] ? pair[pair.length - 1] : pair[0];
        } else {
          textures[sampler] = sceneTextures[input[1]];
        }
      }
      const values = { ...pass.uniforms, u_step: [stepsDone] };
      for (const name of Object.keys(live)) if (name in pass.uniforms) values[name] = live[name];
      use(programs[pass.program], values, textures);
      const pair = state[pass.writes[0]][pass.writes[1]];
      fullscreen(pair[pair.length - 1]);
    }
    for (const name of plan.swap) for (const pair of state[name]) pair.reverse();
    stepsDone += 1;
  }

  // -- density -----------------------------------------------------------------------------------
  const points = programs[plan.points.program];
  const density = {};
  if (path === "float") {
    density.sum = made(target(texture(width, height, gl.FLOAT, false)), "the RGBA32F density");
  } else {
    const type = path === "half" ? halfFloat.HALF_FLOAT_OES : gl.UNSIGNED_BYTE;
    density.batch = made(target(texture(width, height, type, false)), "the density batch");
    density.totals = [0, 1].map(() => made(
      target(texture(width, height, gl.UNSIGNED_BYTE, false)), "the density count"));
  }

  function pointInputs() {
    const textures = {};
    for (const [sampler, input] of Object.entries(plan.points.inputs)) {
      textures[sampler] = state[input[1]][input[2]][0];
    }
    return textures;
  }

  function clear(t) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.framebuffer);
    gl.viewport(0, 0, t.width, t.height);
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT);
  }

  function drawPoints(t, first, count) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.framebuffer);
    gl.viewport(0, 0, t.width, t.height);
    attribute(texelBuffer);
    gl.drawArrays(gl.POINTS, first, count);
  }

  function renderDensity() {
    const intensity = plan.intensity;
    gl.blendFunc(gl.ONE, gl.ONE);
    if (path === "float") {
      clear(density.sum);
      use(points, { ...plan.points.uniforms, u_colour: [intensity, intensity, intensity,
                                                        intensity] }, pointInputs());
      gl.enable(gl.BLEND);
      drawPoints(density.sum, 0, L.count);
      gl.disable(gl.BLEND);
      return density.sum;
    }
    const add = programs[plan.density.add];
    const batch = plan.density.batch[path];
    const quarter = Math.ceil(batch / 4);
    const hit = levels * code;
    clear(density.totals[0]);
    for (let first = 0; first < L.count; first += batch) {
      clear(density.batch);
      use(points, { ...plan.points.uniforms, u_colour: [hit, hit, hit, hit] }, pointInputs());
      gl.enable(gl.BLEND);
      for (let channel = 0; channel < 4; channel += 1) {
        const start = first + channel * quarter;
        const count = Math.min(quarter, L.count - start);
        if (count <= 0) break;
        gl.colorMask(channel === 0, channel === 1, channel === 2, channel === 3);
        drawPoints(density.batch, start, count);
      }
      gl.colorMask(true, true, true, true);
      gl.disable(gl.BLEND);
      use(add, { u_hit: [code], u_full: [path === "bytes" ? 255 : 2048] },
          { u_total: density.totals[0], u_batch: density.batch });
      fullscreen(density.totals[1]);
      density.totals.reverse();
    }
    return density.totals[0];
  }

  // -- post stages, then the canvas ------------------------------------------------------------
  const post = plan.post.map((s) => made(target(texture(s.size[0], s.size[1], gl.UNSIGNED_BYTE,
                                                        true)), `post stage ${s.name}`));

  function renderPost(densityTexture) {
    const textures = { ...fixed, density: densityTexture };
    plan.post.forEach((s, i) => {
      const counts = path !== "float" && s.program_counts !== undefined;
      const inputs = {};
      for (const [sampler, source] of Object.entries(s.inputs)) inputs[sampler] = textures[source];
      const values = counts ? { ...s.uniforms, u_unit: [plan.intensity / levels] } : s.uniforms;
      use(programs[counts ? s.program_counts : s.program], values, inputs);
      fullscreen(post[i]);
      textures[s.name] = post[i];
    });
    return post[post.length - 1];
  }

  let lastDensity = null;
  let lastImage = null;

  function frame() {
    lastDensity = renderDensity();
    lastImage = renderPost(lastDensity);
    use(programs[plan.present], {}, { u_source: lastImage });
    fullscreen(null);
    show("steps", stepsDone);
  }

  function read(t, type, Kind) {
    const out = new Kind(4 * t.width * t.height);
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.framebuffer);
    gl.readPixels(0, 0, t.width, t.height, gl.RGBA, type, out);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    return out;
  }

  // -- the page: warm-up, then play; buttons and sliders --------------------------------------
  for (let i = 0; i < plan.steps; i += 1) step();
  frame();

  let playing = !params.has("paused");
  const playButton = document.getElementById("play");
  const label = () => { playButton.textContent = playing ? "Pause" : "Play"; };
  label();
  playButton.addEventListener("click", () => { playing = !playing; label(); });
  document.getElementById("step").addEventListener("click", () => {
    playing = false;
    label();
    step();
    frame();
  });
  const controls = document.getElementById("controls");
  for (const c of plan.controls) {
    const owner = plan.passes.find((p) => c.uniform in p.uniforms);
    if (owner === undefined) fail(`slider ${c.label}: no pass declares ${c.uniform}`);
    live[c.uniform] = live[c.uniform] || owner.uniforms[c.uniform].slice();
    const row = document.createElement("label");
    const value = document.createElement("output");
    const slider = document.createElement("input");
    Object.assign(slider, { type: "range", min: c.lo, max: c.hi, step: 0.001,
                            value: live[c.uniform][c.component] });
    slider.dataset.control = c.label;
    value.textContent = Number(slider.value).toFixed(3);
    slider.addEventListener("input", () => {
      live[c.uniform][c.component] = Number(slider.value);
      value.textContent = Number(slider.value).toFixed(3);
      if (!playing) { step(); frame(); }
    });
    row.append(c.label, slider, value);
    controls.append(row);
  }

  let frames = 0;
  let since = performance.now();
  function tick(now) {
    if (playing) {
      step();
      frame();
      frames += 1;
      if (now - since > 1000) {
        show("frames a second", (1000 * frames / (now - since)).toFixed(1));
        frames = 0;
        since = now;
      }
    }
    window.requestAnimationFrame(tick);
  }
  window.requestAnimationFrame(tick);

  window.es2particles = {
    facts,
    path,
    // Run n steps, drawing a frame after the last; returns the steps done so far.
    step(n = 1) {
      for (let i = 0; i < n; i += 1) step();
      frame();
      gl.finish();
      return stepsDone;
    },
    pause() { playing = false; label(); },
    // The raw RGBA8 texels of a quantity's part (front texture), width x height, base64.
    state(name, part = 0) {
      if (!(name in state)) fail(`state(${name}): the plan's quantities are ${Object.keys(state)}`);
      return base64(read(state[name][part][0], gl.UNSIGNED_BYTE, Uint8Array));
    },
    // The last frame's density, float32 per pixel (bottom row first), base64, and the pixels a
    // batch channel filled to its top (where the count may be short).
    density() {
      const values = new Float32Array(width * height);
      let flagged = 0;
      if (path === "float") {
        const raw = read(lastDensity, gl.FLOAT, Float32Array);
        for (let i = 0; i < values.length; i += 1) values[i] = raw[4 * i];
      } else {
        const raw = read(lastDensity, gl.UNSIGNED_BYTE, Uint8Array);
        const unit = plan.intensity / levels;
        for (let i = 0; i < values.length; i += 1) {
          values[i] = (raw[4 * i] + 256 * raw[4 * i + 1] + 65536 * raw[4 * i + 2]) * unit;
          if (raw[4 * i + 3] > 0) flagged += 1;
        }
      }
      return { values: base64(values), flagged };
    },
    // The last frame's image (RGBA8, bottom row first), base64.
    image() { return base64(read(lastImage, gl.UNSIGNED_BYTE, Uint8Array)); },
  };
  document.body.dataset.ready = "yes";
}());
