// The es2particles executor of a WebGL 1 page: runs the frame plan that es2particles/export/page.py
// wrote into this page, stage by stage, as the EGL executor (es2particles/frame/executor.py) runs
// it: every resource made once (state, images, targets, vertex data), then each step's passes and
// each frame's stages drawn in order with the same GLSL ES 1.00 sources the EGL run compiles.
// No network: everything it needs is in the page.
//
// window.es2particles is its interface for tests and the console: step(n), state(name, part),
// resource(name, part), density(), image(), orbit(dx, dy), zoom(factor), and what the context
// offers (facts).
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
  const pointRange = Array.from(gl.getParameter(gl.ALIASED_POINT_SIZE_RANGE));
  show("vertex texture units", vertexUnits);
  show("fragment highp", highp > 0 ? `yes (${highp}-bit significand)` : "no");
  show("point size range", `${pointRange[0]}..${pointRange[1]}`);
  show("vertex texture fetch", plan.vertex_fetch ? "used"
    : "not used: the state is read back into vertex buffers each frame");
  const missing = [];
  if (vertexUnits < 1 && plan.vertex_fetch) {
    missing.push("vertex texture fetch: MAX_VERTEX_TEXTURE_IMAGE_UNITS is 0, so the vertex " +
                 "shader cannot read the particles' positions (export the scene with " +
                 "--vertex-fetch off to read them back each frame instead)");
  }
  if (highp < 1) {
    missing.push("highp float in fragment shaders: the 16-bit packed state and the passes' " +
                 "arithmetic need it");
  }
  const side = Math.max(width, height,
                        ...Object.values(plan.resources).map((r) => Math.max(r.width, r.height)));
  if (side > maxTexture) {
    missing.push(`textures ${side} texels wide: this context's limit is ${maxTexture}`);
  }
  for (const stage of plan.stages) {
    const size = stage.uniforms.u_point_size;
    if (size !== undefined && size[0] > pointRange[1]) {
      missing.push(`points of ${size[0]} pixels: this context's largest is ${pointRange[1]}`);
    }
  }
  const floatTexture = gl.getExtension("OES_texture_float");
  const halfTexture = gl.getExtension("OES_texture_half_float");
  // WebGL 1 filters a float or half-float texture linearly only where these are enabled; one
  // sampled linearly without them reads black (an incomplete texture).
  const filters = {
    [gl.UNSIGNED_BYTE]: true,
    [gl.FLOAT]: gl.getExtension("OES_texture_float_linear") !== null,
    [halfTexture ? halfTexture.HALF_FLOAT_OES : -1]:
      gl.getExtension("OES_texture_half_float_linear") !== null,
  };
  const usesFloat = Object.values(plan.resources).some((r) => r.type === "float");
  if (usesFloat && !floatTexture) missing.push("OES_texture_float: the scene samples float textures");
  if (missing.length) {
    fail("This context lacks what the scene needs (the ES 2.0 article's requirements):\n- " +
         missing.join("\n- "));
  }

  // -- textures, framebuffers and formats --------------------------------------------------------
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

  function target(t, depth) {
    t.framebuffer = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.framebuffer);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, t.texture, 0);
    if (depth) {
      gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
    }
    const complete = gl.checkFramebufferStatus(gl.FRAMEBUFFER) === gl.FRAMEBUFFER_COMPLETE;
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    return complete ? t : null;
  }

  function made(t, what) {
    if (t === null) fail(`${what}: the context cannot render into it`);
    return t;
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

  function renders(type) {  // a small target of this type, made and deleted again
    const probe = texture(4, 4, type, false);
    const complete = target(probe) !== null;
    gl.deleteFramebuffer(probe.framebuffer);
    gl.deleteTexture(probe.texture);
    return complete;
  }

  const TYPES = {  // format -> the texture type, where the context can render and blend into it
    rgba8: () => gl.UNSIGNED_BYTE,
    rgba32f: () => floatTexture && gl.getExtension("WEBGL_color_buffer_float") &&
                   gl.getExtension("EXT_float_blend") && renders(gl.FLOAT) ? gl.FLOAT : null,
    rgba16f: () => halfTexture && gl.getExtension("EXT_color_buffer_half_float") &&
                   renders(halfTexture.HALF_FLOAT_OES) ? halfTexture.HALF_FLOAT_OES : null,
  };

  // -- the density path: the first the context offers, or the one the address asks for --------
  const HOW = {
    float: "float: additive points into RGBA32F (WEBGL_color_buffer_float, EXT_float_blend)",
    half: "half: batches of points into RGBA16F (EXT_color_buffer_half_float), added to an " +
          "exact count in RGBA8",
    bytes: "bytes: batches of points into RGBA8, a quarter of each per channel, added to an " +
           "exact count in RGBA8 (no extension)",
  };
  let path = null;
  if (plan.density) {
    const offers = { float: () => TYPES.rgba32f() !== null, half: () => TYPES.rgba16f() !== null,
                     bytes: () => true };
    const asked = params.get("density");
    if (asked !== null && !plan.density.paths.includes(asked)) {
      fail(`density=${asked}: the paths are ${plan.density.paths.join(", ")}`);
    }
    path = (asked !== null ? [asked] : plan.density.paths).find((name) => offers[name]());
    if (path === undefined && plan.density.hue) {
      fail("colour by a quantity (the wind's speed): the page sums it in an RGBA32F target, " +
           "which this context cannot blend into (WEBGL_color_buffer_float, EXT_float_blend)");
    }
    if (path === undefined) fail(`density=${asked}: this context does not offer it`);
    show("density", HOW[path] + (asked !== null ? " (asked for)" : ""));
  }
  // A hit adds `levels` codes (fading points fewer); a code is 1/255 of a byte or 1.0 of a half.
  const levels = plan.density && plan.density.fade && path !== "float"
    ? plan.density.fade_levels[path] : 1;
  const code = path === "bytes" ? 1 / 255 : 1;

  // -- programs --------------------------------------------------------------------------------
  const SIZES = { [gl.FLOAT]: 1, [gl.FLOAT_VEC2]: 2, [gl.FLOAT_VEC3]: 3, [gl.FLOAT_VEC4]: 4,
                  [gl.FLOAT_MAT4]: 16 };
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
    // The vertex shader's samplers each take a vertex texture unit (ES 2.0 promises none).
    const vertexSamplers = samplers.filter((n) => new RegExp(`\\b${n}\\b`).test(
      p.vertex.replace(/uniform[^;]*;/g, "")));
    if (vertexSamplers.length > vertexUnits) {
      fail(`${p.name}: its vertex shader samples ${vertexSamplers.length} textures; this ` +
           `context allows ${vertexUnits} (MAX_VERTEX_TEXTURE_IMAGE_UNITS)`);
    }
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
      const data = new Float32Array(value.slice(0, size * u.size));
      if (u.type === gl.FLOAT_MAT4) gl.uniformMatrix4fv(u.location, false, data);
      else gl[SETTERS[size]](u.location, data);
    }
    p.samplers.forEach((name, unit) => {
      const t = textures[name];
      if (t === undefined) fail(`${p.name}: sampler ${name} is used but nothing feeds it`);
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, t.texture);
    });
  }

  // -- vertex data -------------------------------------------------------------------------------
  const triangle = { buffer: gl.createBuffer(), attributes: [["a_position", 2]] };
  gl.bindBuffer(gl.ARRAY_BUFFER, triangle.buffer);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
  const vertexData = {};
  for (const [name, v] of Object.entries(plan.vertices)) {
    let data;
    if (v.source === "texels") {
      // Each cell's texel centre, row by row: the vertex shader's index (ES 1.00 has no
      // gl_VertexID). Rounded to float32 as numpy's Layout.texel_uv rounds it.
      data = new Float32Array(2 * v.count);
      for (let i = 0; i < v.count; i += 1) {
        data[2 * i] = ((i % v.width) + 0.5) / v.width;
        data[2 * i + 1] = (Math.floor(i / v.width) + 0.5) / v.height;
      }
    } else {
      data = new Float32Array(bytes(v.data).buffer);
    }
    const buffer = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
    vertexData[name] = { buffer, attributes: v.attributes, count: v.count };
    if (v.indices !== undefined) {
      // One static index buffer (quads as two triangles): 32-bit indices where the context has
      // OES_element_index_uint, else 16-bit ones, which reach 65536 vertices.
      const wide = new Uint32Array(bytes(v.indices).buffer);
      const uint = gl.getExtension("OES_element_index_uint");
      if (!uint && v.count > 65536) {
        fail(`${name}: ${v.count} vertices need 32-bit indices, and this context has no ` +
             "OES_element_index_uint");
      }
      const elements = gl.createBuffer();
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, elements);
      gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, uint ? wide : Uint16Array.from(wide), gl.STATIC_DRAW);
      vertexData[name].elements = elements;
      vertexData[name].indexType = uint ? gl.UNSIGNED_INT : gl.UNSIGNED_SHORT;
    }
  }

  // A stage whose vertex shader reads the state from attributes (no vertex texture fetch): each
  // part's texels read back and uploaded before the draw, bytes normalised as a sampler gives them.
  const readBackBuffers = {};
  function readBack(stage) {
    const list = [];
    for (const [attribute, [name, part]] of Object.entries(stage.attributes)) {
      const t = front(name, part);
      const texels = read(t, gl.UNSIGNED_BYTE, Uint8Array).subarray(0, 4 * stage.count);
      const key = `${stage.name} ${attribute}`;
      readBackBuffers[key] = readBackBuffers[key] || gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, readBackBuffers[key]);
      gl.bufferData(gl.ARRAY_BUFFER, texels, gl.STREAM_DRAW);
      list.push({ buffer: readBackBuffers[key], name: attribute });
    }
    // the stage's own vertex data too, where it has some (the sprites' texels: their hashes)
    const own = stage.vertices === null ? null : vertexData[stage.vertices];
    return { readBack: list, count: stage.count, own };
  }

  let enabled = [];
  function attributes(p, vertices) {
    for (const location of enabled) gl.disableVertexAttribArray(location);
    enabled = [];
    if (vertices.readBack) {
      for (const { buffer, name } of vertices.readBack) {
        const location = gl.getAttribLocation(p.program, name);
        if (location < 0) continue;
        gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
        gl.enableVertexAttribArray(location);
        gl.vertexAttribPointer(location, 4, gl.UNSIGNED_BYTE, true, 0, 0);
        enabled.push(location);
      }
      if (vertices.own) floats(p, vertices.own);
      return;
    }
    floats(p, vertices);
  }

  function floats(p, vertices) {  // interleaved float attributes of vertex data
    gl.bindBuffer(gl.ARRAY_BUFFER, vertices.buffer);
    const stride = 4 * vertices.attributes.reduce((sum, [, n]) => sum + n, 0);
    let offset = 0;
    for (const [name, n] of vertices.attributes) {
      const location = gl.getAttribLocation(p.program, name);
      if (location >= 0) {
        gl.enableVertexAttribArray(location);
        gl.vertexAttribPointer(location, n, gl.FLOAT, false, stride, offset);
        enabled.push(location);
      }
      offset += 4 * n;
    }
  }

  // -- resources: state, images and targets, made once ------------------------------------------
  const uniformsOf = {};  // a fallback format's uniforms, for every stage that sets them
  const resources = {};
  for (const [name, r] of Object.entries(plan.resources)) {
    const texels = r.width * r.height;
    if (r.kind === "state") {
      const parts = r.parts_data !== undefined ? r.parts_data.map(bytes) : r.clear.map((t) => {
        const data = new Uint8Array(4 * texels);
        for (let i = 0; i < data.length; i += 4) data.set(t, i);
        return data;
      });
      resources[name] = parts.map((data, part) => Array.from({ length: r.buffers }, () =>
        made(target(texture(r.width, r.height, gl.UNSIGNED_BYTE, false, data)),
             `state ${name} part ${part + 1}`)));
    } else if (r.kind === "image") {
      const astc = r.astc && gl.getExtension("WEBGL_compressed_texture_astc");
      let t;
      if (astc) {
        t = texture(r.width, r.height, gl.UNSIGNED_BYTE, r.linear);
        gl.compressedTexImage2D(gl.TEXTURE_2D, 0, r.astc.internal_format, r.width, r.height, 0,
                                bytes(r.astc.data));
      } else if (r.type === "float") {
        t = texture(r.width, r.height, gl.FLOAT, r.linear, new Float32Array(bytes(r.data).buffer));
      } else {
        t = texture(r.width, r.height, gl.UNSIGNED_BYTE, r.linear, bytes(r.data));
      }
      if (r.astc) {
        show(`texture ${name}`, astc ? `ASTC ${r.astc.block.join("x")} blocks, as compressed`
          : "ASTC blocks decoded before upload: this context offers no " +
            "WEBGL_compressed_texture_astc, so the texels they decode to are sent");
      }
      resources[name] = [[t]];
    } else if (plan.density && name === "density") {
      resources[name] = null;  // the density path's own textures, below
    } else {
      let type = null;
      let format = r.format;
      for (const option of r.fallbacks || [{ format: r.format }]) {
        type = TYPES[option.format] ? TYPES[option.format]() : null;
        if (type !== null) {
          format = option.format;
          if (option.uniforms) Object.assign(uniformsOf, option.uniforms);
          break;
        }
      }
      if (type === null) fail(`target ${name}: this context can render into none of its formats`);
      if (format !== r.format) show(`target ${name}`, `${format} (the context has no ${r.format})`);
      if (r.linear && !filters[type]) {  // read through linear filtering: bytes filter everywhere
        show(`target ${name}`, `rgba8 (the context cannot filter ${format} linearly)`);
        type = gl.UNSIGNED_BYTE;
        format = "rgba8";
      }
      const depth = r.depth ? gl.createRenderbuffer() : null;
      if (depth) {
        gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
        gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT16, r.width, r.height);
      }
      const start = r.data !== undefined ? (r.type === "float"
        ? new Float32Array(bytes(r.data).buffer) : bytes(r.data)) : null;
      resources[name] = Array.from({ length: r.parts }, () => Array.from(
        { length: r.buffers }, (_, k) => made(target(texture(r.width, r.height, type, r.linear,
                                                             k === 0 ? start : null), depth),
                                              `target ${name}`)));
      resources[name].depth = depth;
    }
  }

  function front(name, part = 0) {
    return resources[name][part][0];
  }

  function back(name, part = 0) {
    const pair = resources[name][part];
    return pair[pair.length - 1];
  }

  function swap(name) {
    for (const pair of resources[name]) pair.reverse();
  }

  // -- the camera: the plan's, then the mouse's ---------------------------------------------------
  const camera = plan.camera && (() => {
    const c = plan.camera;
    const sub = (a, b) => a.map((v, i) => v - b[i]);
    const dot = (a, b) => a.reduce((s, v, i) => s + v * b[i], 0);
    const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                             a[0] * b[1] - a[1] * b[0]];
    const unit = (a) => { const n = Math.hypot(...a); return a.map((v) => v / n); };
    // The mouse orbits about the camera's up axis through the target: azimuth from the eye's
    // first direction across that axis (along), elevation towards the axis.
    const offset = sub(c.eye, c.target), radius = Math.hypot(...offset);
    const up = unit(c.up), height = dot(offset, up);
    let level = sub(offset, up.map((v) => v * height));
    if (Math.hypot(...level) < 1e-9 * radius) {  // looking along the up axis: any side will do
      level = cross(up, Math.abs(up[0]) < 0.9 ? [1, 0, 0] : [0, 0, 1]);
    }
    const along = unit(level), side = cross(up, along);
    const state = {
      moved: false, radius, azimuth: 0,
      elevation: Math.asin(Math.max(-1, Math.min(1, height / radius))),
    };
    function eye() {
      if (!state.moved) return c.eye;
      const r = state.radius, e = state.elevation, a = state.azimuth;
      return c.target.map((t, i) => t + r * (Math.cos(e) * (Math.cos(a) * along[i]
                                                             + Math.sin(a) * side[i])
                                             + Math.sin(e) * up[i]));
    }
    function forward() { return unit(sub(c.target, eye())); }
    function focal(h) { return h / 2 / Math.tan(c.fov * Math.PI / 360); }
    function viewProjection(aspect) {  // column-major, as camera.py's uniform
      const e = eye(), f = forward(), s = unit(cross(f, c.up)), u = cross(s, f);
      const view = [[...s, -dot(s, e)], [...u, -dot(u, e)], [-f[0], -f[1], -f[2], dot(f, e)],
                    [0, 0, 0, 1]];
      const n = c.near, far = c.far;
      let p;
      if (c.ortho == null) {
        const t = 1 / Math.tan(c.fov * Math.PI / 360);
        p = [[t / aspect, 0, 0, 0], [0, t, 0, 0],
             [0, 0, (far + n) / (n - far), 2 * far * n / (n - far)], [0, 0, -1, 0]];
      } else {  // orthographic: a half-height in world units, scaled as the wheel zooms
        const h = c.ortho * state.radius / radius;
        p = [[1 / (h * aspect), 0, 0, 0], [0, 1 / h, 0, 0],
             [0, 0, -2 / (far - n), -(far + n) / (far - n)], [0, 0, 0, 1]];
      }
      const out = [];
      for (let col = 0; col < 4; col += 1) {
        for (let row = 0; row < 4; row += 1) {
          out.push(p[row].reduce((sum, v, k) => sum + v * view[k][col], 0));
        }
      }
      return out;
    }
    function depthRange(lo, hi) {
      const e = eye(), f = forward();
      let near = Infinity, far = -Infinity;
      for (let corner = 0; corner < 8; corner += 1) {
        const p = [0, 1, 2].map((a) => ((corner >> a) & 1 ? hi : lo)[a]);
        const d = dot(sub(p, e), f);
        near = Math.min(near, d);
        far = Math.max(far, d);
      }
      return [far, 1 / Math.max(far - near, 1e-30)];
    }
    return {
      state, eye, forward, focal, viewProjection, depthRange,
      orbit(dx, dy) {  // the window's constants (live/controls.py), serialised with the camera
        state.moved = true;
        state.azimuth -= dx * c.orbit_rate;
        state.elevation = Math.max(-c.elevation_limit,
                                   Math.min(c.elevation_limit, state.elevation + dy * c.orbit_rate));
      },
      zoom(factor) {
        state.moved = true;
        const [lo, hi] = c.distance_limits;
        state.radius = Math.max(lo, Math.min(hi, state.radius * factor));
      },
      // The ray [origin, direction] through pixel (x, y) of the picture, y down from the top
      // (live/controls.py: ViewCamera.ray).
      ray(x, y) {
        const [w, h] = plan.size;  // (this closure's `height` is the eye's over the target)
        const px = (2 * x / w - 1) * w / h, py = 1 - 2 * y / h;
        const e = eye(), f = forward(), s = unit(cross(f, c.up)), u = cross(s, f);
        const across = s.map((v, i) => px * v + py * u[i]);
        if (c.ortho == null) {
          const t = Math.tan(c.fov * Math.PI / 360);
          return [e, unit(f.map((v, i) => v + t * across[i]))];
        }
        const half = c.ortho * state.radius / radius;
        return [e.map((v, i) => v + half * across[i]), f];
      },
    };
  })();

  // The scene's grip (the smoke's sphere): where a drag has put its rest centre; the passes
  // take it, and its velocity while it moves, at the next step (live/controls.py).
  const grip = plan.grip && {
    centre: plan.grip.centre.slice(), stepped: plan.grip.centre.slice(),
    // Its centre as drawn after `step` steps, to pick it: lib/motion.glsl's motion_pose (the
    // sway about the rest centre), the page's one copy of it, which draws nothing (the meshes
    // and the passes place the sphere in the shader; tests/test_export.py drags it).
    drawn(step) {
      const u = motionUniforms(step), sway = u.u_motion_sway;
      const s = sway[3] > 0 ? Math.sin(2 * Math.PI / sway[3] * u.u_motion_time[0]) : 0;
      return [0, 1, 2].map((i) => u.u_motion_pivot[i] + u.u_motion_offset[i] + sway[i] * s);
    },
    hit(origin, direction) {  // the distance along the ray to the sphere, or null
      const c = grip.drawn(stepsDone), oc = origin.map((v, i) => v - c[i]);
      const b = oc.reduce((s, v, i) => s + v * direction[i], 0);
      const disc = b * b - (oc.reduce((s, v) => s + v * v, 0) - plan.grip.radius ** 2);
      if (disc < 0) return null;
      let t = -b - Math.sqrt(disc);
      if (t < 0) t = -b + Math.sqrt(disc);
      return t < 0 ? null : origin.map((v, i) => v + t * direction[i]);
    },
    drag(start, grabbed, origin, direction) {
      if (Math.abs(direction[1]) < 1e-9) return;
      const t = (grabbed[1] - origin[1]) / direction[1];
      if (t <= 0) return;
      const g = plan.grip, clamp = (v, [lo, hi]) => Math.max(lo, Math.min(hi, v));
      grip.centre = [clamp(start[0] + origin[0] + t * direction[0] - grabbed[0], g.x_range),
                     start[1],
                     clamp(start[2] + origin[2] + t * direction[2] - grabbed[2], g.z_range)];
    },
    beforeStep() {  // the centre and its velocity for this step
      const dt = plan.motion.dt, g = plan.grip;
      live[g.velocity] = grip.centre.map((v, i) => (v - grip.stepped[i]) / dt);
      live[g.uniform] = grip.centre.slice();
      grip.stepped = grip.centre.slice();
    },
  };

  // The scene's push (the wind's air): while the button is down, the pointer's world point and
  // its velocity over the last step (how far it moved since, over the step's dt) go to the
  // passes at each step, as the grip's do; when it comes up the push stops (scenes/base.py: Push).
  const push = plan.push && {
    at: null, stepped: null,
    beforeStep() {
      const p = plan.push;
      if (push.at === null) return;
      live[p.velocity] = push.at.map((v, i) => (v - push.stepped[i]) / p.dt);
      live[p.at] = [...push.at, p.radius, 1];
      push.stepped = push.at.slice();
    },
    release() {
      push.at = push.stepped = null;
      live[plan.push.at] = [0, 0, 1, 0];
      live[plan.push.velocity] = [0, 0];
    },
  };

  // lib/motion.glsl's uniforms after `step` steps: the plan's (frame/plan.py: motion_values),
  // its time, and its rest offset moved by the grip's drag.
  function motionUniforms(step) {
    const m = plan.motion, u = {...m.uniforms, u_motion_time: [step * m.dt]};
    if (grip) {
      u.u_motion_offset = u.u_motion_offset.map((v, i) => v + grip.centre[i] - plan.grip.centre[i]);
    }
    return u;
  }

  let stepsDone = 0;
  function frameValue(stage, name, spec, aspect) {
    const initial = stage.initial[name];
    const exact = initial !== undefined && camera && !camera.state.moved;
    switch (spec[0]) {
      case "step": return [stepsDone];
      case "motion": return motionUniforms(stepsDone)[spec[1]];
      case "sprite_size": return [spec[1], spec[2], ...pointRange];
      case "jogl_sprite_size": {  // the JOGL seed's law: over the squared xz distance fraction
        if (exact) return [initial[0], initial[1], ...pointRange];
        const e = camera.eye(), dx = e[0] - spec[3], dz = e[2] - spec[4];
        return [spec[1] * spec[5] * spec[5] / Math.max(dx * dx + dz * dz, 1e-12), spec[2],
                ...pointRange];
      }
      case "light_size": {
        const size = exact ? initial[0] : spec[1] / camera.focal(spec[4]) * spec[2];
        return [size, spec[3], ...pointRange];
      }
      case "view_projection": return exact ? initial : camera.viewProjection(aspect);
      case "eye": return exact ? initial : camera.eye();
      case "forward": return exact ? initial : camera.forward();
      case "depth_range": return exact ? initial : camera.depthRange(spec[1], spec[2]);
      case "depth_planes": return [plan.camera.near, plan.camera.far,
                                   plan.camera.ortho == null ? 0 : 1];
      default: return fail(`${stage.name}: unknown frame value ${spec[0]}`);
    }
  }

  // -- running a stage: the same for every kind ---------------------------------------------------
  const BLENDS = { add: () => gl.blendFunc(gl.ONE, gl.ONE),
                   over: () => gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA),
                   multiply: () => gl.blendFunc(gl.ZERO, gl.SRC_COLOR) };
  const live = {};  // uniform -> values the sliders set
  const cursors = {};
  // What a frame or a sample changes (the plan's animation and samples tables): uniform ->
  // values now. A slider moved takes its uniform from the animation for good (the hand wins).
  const scheduled = {};
  const handed = new Set();
  let frameIndex = 0;
  const sliders = [];  // {control, slider, value}: shown values follow the animation
  function setFrame(f) {
    const row = plan.animation[Math.min(f, plan.animation.length - 1)] || {};
    for (const [name, value] of Object.entries(row)) {
      if (!handed.has(name)) scheduled[name] = value;
    }
    for (const { control, slider, value } of sliders) {
      if (control.uniform in scheduled) {
        slider.value = scheduled[control.uniform][control.component];
        value.textContent = Number(slider.value).toFixed(3);
      }
    }
  }
  function setSample(s) {
    for (const [name, value] of Object.entries(plan.samples[s])) scheduled[name] = value;
  }

  function inputs(stage) {
    const textures = {};
    for (const [sampler, [name, part, when]] of Object.entries(stage.inputs)) {
      if (name === "density" && plan.density) textures[sampler] = densityTexture;
      else textures[sampler] = when === "written" ? back(name, part) : front(name, part);
    }
    return textures;
  }

  function bindTarget(t, clear, hasDepth) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.framebuffer);
    gl.viewport(0, 0, t.width, t.height);
    if (clear) {
      gl.clearColor(...clear);
      gl.depthMask(true);
      gl.clearDepth(1);
      gl.clear(gl.COLOR_BUFFER_BIT | (hasDepth ? gl.DEPTH_BUFFER_BIT : 0));
    }
  }

  function draw(stage, p, vertices, first, count) {
    const state = stage.state;
    if (state.blend) { gl.enable(gl.BLEND); BLENDS[state.blend](); }
    if (state.depth_test) { gl.enable(gl.DEPTH_TEST); gl.depthMask(state.depth_write); }
    if (state.colour_write === false) gl.colorMask(false, false, false, false);
    attributes(p, vertices);
    const mode = stage.primitive === "points" ? gl.POINTS : gl.TRIANGLES;
    if (vertices.elements) {
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, vertices.elements);
      const size = vertices.indexType === gl.UNSIGNED_INT ? 4 : 2;
      gl.drawElements(mode, count, vertices.indexType, first * size);
    } else {
      gl.drawArrays(mode, first, count);
    }
    gl.colorMask(true, true, true, true);
    gl.disable(gl.BLEND);
    gl.disable(gl.DEPTH_TEST);
    gl.depthMask(true);
  }

  function values(stage, aspect) {
    const out = { ...stage.uniforms };
    for (const name of Object.keys(live)) if (name in out) out[name] = live[name];
    for (const name of Object.keys(scheduled)) if (name in out) out[name] = scheduled[name];
    for (const name of Object.keys(uniformsOf)) if (name in out) out[name] = uniformsOf[name];
    for (const [name, spec] of Object.entries(stage.frame_uniforms)) {
      out[name] = frameValue(stage, name, spec, aspect);
    }
    return out;
  }

  function run(stage) {
    if (stage.kind === "points" && plan.density) return drawDensity(stage);
    const [name, part] = stage.target;
    const r = plan.resources[name];
    const p = programs[stage.program];
    const fetched = Object.keys(stage.attributes).length > 0;
    const vertices = fetched ? readBack(stage)
      : (stage.vertices === null ? triangle : vertexData[stage.vertices]);
    const count = fetched ? stage.count : (stage.vertices === null ? 3
      : (stage.count === null ? vertices.count : stage.count));
    const base = values(stage, r.width / r.height);
    const swaps = r.swap === "draw";
    if (stage.clear) bindTarget(back(name, part), stage.clear, r.depth);
    let draws = [null];
    if (stage.repeat.length) {
      const n = stage.repeat.length;
      if (stage.per_frame === null || stage.per_frame >= n) {
        draws = stage.repeat.map((_, i) => i);
      } else {
        const cursor = cursors[stage.name] || 0;
        cursors[stage.name] = (cursor + stage.per_frame) % n;
        draws = Array.from({ length: stage.per_frame }, (_, i) => (cursor + i) % n);
      }
    }
    for (const index of draws) {
      use(p, index === null ? base : { ...base, ...stage.repeat[index] }, inputs(stage));
      bindTarget(back(name, part), null, r.depth);
      draw(stage, p, vertices, 0, count);
      if (swaps) swap(name);
    }
    // An accumulating stage (a flame's marches averaged): each further sample after a step of
    // its own, added into the same target, as Executor.render draws them.
    for (let s = 1; s < stage.samples; s += 1) {
      setSample(s);
      step();
      use(p, values(stage, r.width / r.height), inputs(stage));
      bindTarget(back(name, part), null, r.depth);
      draw(stage, p, vertices, 0, count);
    }
    if (stage.samples > 1) setSample(0);  // the next frame starts as a plain one would
    return null;
  }

  // -- one step: every pass in the plan's order, then the ping-pong swap -----------------------
  const stepStages = plan.stages.filter((s) => s.step);
  const frameStages = plan.stages.filter((s) => !s.step);
  const swapped = Object.entries(plan.resources).filter(([, r]) => r.swap === "step")
    .map(([name]) => name);

  // Rounds of the step, as executor.py's step_rounds makes them: a run of consecutive stages of
  // one loop (a repeat of the pass graph) drawn its count of times, every other stage once. A
  // stage with swap set swaps its target right after it (a versioned quantity's write).
  const rounds = [];
  for (const stage of stepStages) {
    const last = rounds[rounds.length - 1];
    const same = stage.loop && last && last.stages[last.stages.length - 1].loop
      && last.stages[last.stages.length - 1].loop[0] === stage.loop[0];
    if (same) last.stages.push(stage);
    else rounds.push({ stages: [stage], count: stage.loop ? stage.loop[1] : 1 });
  }

  function step() {
    if (grip) grip.beforeStep();
    if (push) push.beforeStep();
    for (const round of rounds) {
      for (let i = 0; i < round.count; i += 1) {
        for (const stage of round.stages) {
          run(stage);
          if (stage.swap) swap(stage.target[0]);
        }
      }
    }
    for (const name of swapped) swap(name);
    stepsDone += 1;
  }

  // -- the density of 2D scenes, by the path taken ----------------------------------------------
  const density = {};
  let densityTexture = null;
  if (plan.density) {
    if (path === "float") {
      density.sum = made(target(texture(width, height, gl.FLOAT, false)), "the RGBA32F density");
    } else {
      const type = path === "half" ? halfTexture.HALF_FLOAT_OES : gl.UNSIGNED_BYTE;
      density.batch = made(target(texture(width, height, type, false)), "the density batch");
      density.totals = [0, 1].map(() => made(
        target(texture(width, height, gl.UNSIGNED_BYTE, false)), "the density count"));
    }
  }

  // The density of a frame: its stage's samples, each after a step of its own (sample 0's was
  // the frame's), summed into one target, as Executor.render draws them.
  function drawDensity(stage) {
    drawSample(stage, true);
    for (let s = 1; s < stage.samples; s += 1) {
      setSample(s);
      step();
      drawSample(stage, false);
    }
    if (stage.samples > 1) setSample(0);  // the next frame starts as a plain one would
    return null;
  }

  function drawSample(stage, first) {
    const p = programs[stage.program];
    const vertices = Object.keys(stage.attributes).length ? readBack(stage)
      : vertexData[stage.vertices];
    const count = stage.count;
    const intensity = plan.density.intensity;
    const base = values(stage, width / height);
    if (path === "float") {
      bindTarget(density.sum, first ? [0, 0, 0, 0] : null, false);
      use(p, { ...base, u_colour: [intensity, intensity, intensity, intensity] }, inputs(stage));
      draw(stage, p, vertices, 0, count);
      densityTexture = density.sum;
      return null;
    }
    const add = programs[plan.density.add];
    const batch = plan.density.batch[path];
    const quarter = Math.ceil(batch / 4);
    const hit = levels * code;
    if (first) bindTarget(density.totals[0], [0, 0, 0, 0], false);
    for (let start0 = 0; start0 < count; start0 += batch) {
      bindTarget(density.batch, [0, 0, 0, 0], false);
      use(p, { ...base, u_colour: [hit, hit, hit, hit] }, inputs(stage));
      for (let channel = 0; channel < 4; channel += 1) {
        const start = start0 + channel * quarter;
        const n = Math.min(quarter, count - start);
        if (n <= 0) break;
        gl.colorMask(channel === 0, channel === 1, channel === 2, channel === 3);
        bindTarget(density.batch, null, false);
        draw(stage, p, vertices, start, n);
      }
      gl.colorMask(true, true, true, true);
      use(add, { u_hit: [code], u_full: [path === "bytes" ? 255 : 2048] },
          { u_total: density.totals[0], u_batch: density.batch });
      bindTarget(density.totals[1], null, false);
      draw({ state: {}, primitive: "triangles" }, add, triangle, 0, 3);
      density.totals.reverse();
    }
    densityTexture = density.totals[0];
    return null;
  }

  // The tone map reads a whole count where the density is counted in bytes.
  for (const stage of frameStages) {
    if (stage.program_counts !== undefined && path !== null && path !== "float") {
      stage.program = stage.program_counts;
      stage.uniforms = { ...stage.uniforms, u_unit: [plan.density.intensity / levels] };
    }
  }

  // -- a frame: its stages in order, then the canvas ----------------------------------------------
  const present = programs[plan.present_program];
  function frame() {
    for (const stage of frameStages) run(stage);
    use(present, {}, { u_source: front(plan.present) });
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, width, height);
    draw({ state: {}, primitive: "triangles" }, present, triangle, 0, 3);
    show("steps", stepsDone);
  }

  function read(t, type, Kind) {
    const out = new Kind(4 * t.width * t.height);
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.framebuffer);
    gl.readPixels(0, 0, t.width, t.height, gl.RGBA, type, out);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    return out;
  }

  // The next frame of the run, as Pipeline.frames makes it: its uniforms, its steps (the run's
  // steps per frame, or while playing the clock's), its draw.
  function nextFrame(steps = plan.steps_per_frame) {
    frameIndex += 1;
    setFrame(frameIndex);
    for (let i = 0; i < steps; i += 1) step();
    frame();
    return steps;
  }

  // The clock of a playing page, as a live window keeps it (LiveView.advance, the plan's
  // clock): the steps the seconds since the last frame are worth at the scene's time step, at
  // most max_steps; a scene without a time step steps once a frame.
  let debt = 0;
  function stepsFor(elapsed) {
    const { dt, max_steps: most } = plan.clock;
    if (dt === null) return 1;
    debt += elapsed;
    const steps = Math.min(Math.floor(debt / dt), most);
    debt = Math.min(debt - steps * dt, dt);
    return steps;
  }

  // -- the page: warm-up, then play; buttons, sliders and the mouse --------------------------------
  setFrame(0);
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
    nextFrame();
  });
  const controls = document.getElementById("controls");
  for (const c of plan.controls) {
    const owner = plan.stages.find((s) => c.uniform in s.uniforms);
    if (owner === undefined) fail(`slider ${c.label}: no stage declares ${c.uniform}`);
    live[c.uniform] = live[c.uniform] || owner.uniforms[c.uniform].slice();
    const row = document.createElement("label");
    const value = document.createElement("output");
    const slider = document.createElement("input");
    Object.assign(slider, { type: "range", min: c.lo, max: c.hi, step: 0.001,
                            value: live[c.uniform][c.component] });
    slider.dataset.control = c.label;
    value.textContent = Number(slider.value).toFixed(3);
    slider.addEventListener("input", () => {
      if (c.uniform in scheduled) {  // the hand takes over from the animated values
        live[c.uniform] = scheduled[c.uniform].slice();
        delete scheduled[c.uniform];
      }
      handed.add(c.uniform);
      live[c.uniform][c.component] = Number(slider.value);
      value.textContent = Number(slider.value).toFixed(3);
      if (!playing) { step(); frame(); }
    });
    row.append(c.label, slider, value);
    controls.append(row);
    sliders.push({ control: c, slider, value });
  }
  // A pointer's pixel in the picture (the canvas may be shown scaled).
  const pixel = (e) => {
    const box = canvas.getBoundingClientRect();
    return [(e.clientX - box.left) * width / box.width,
            (e.clientY - box.top) * height / box.height];
  };
  if (push) {
    show("air", "drag to push it");
    const world = (e) => {  // the world point under the pointer (rows from the top)
      const [x, y] = pixel(e), [x0, y0, x1, y1] = plan.push.view;
      return [x0 + (x + 0.5) / width * (x1 - x0), y1 - (y + 0.5) / height * (y1 - y0)];
    };
    canvas.addEventListener("mousedown", (e) => { push.at = push.stepped = world(e); });
    window.addEventListener("mousemove", (e) => { if (push.at !== null) push.at = world(e); });
    window.addEventListener("mouseup", () => { if (push.at !== null) push.release(); });
  }
  if (camera) {
    show("camera", "drag to orbit, wheel to zoom");
    if (grip) show("sphere", "drag it over the floor");
    let dragging = null, held = null;
    canvas.addEventListener("mousedown", (e) => {
      dragging = [e.clientX, e.clientY];
      const [origin, direction] = camera.ray(...pixel(e));
      const grabbed = grip && grip.hit(origin, direction);
      held = grabbed ? [grip.centre.slice(), grabbed] : null;
    });
    window.addEventListener("mouseup", () => { dragging = held = null; });
    window.addEventListener("mousemove", (e) => {
      if (dragging === null) return;
      if (held) grip.drag(held[0], held[1], ...camera.ray(...pixel(e)));
      else camera.orbit(e.clientX - dragging[0], e.clientY - dragging[1]);
      dragging = [e.clientX, e.clientY];
      if (!playing) frame();
    });
    canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      camera.zoom(Math.exp(e.deltaY / 100 * plan.camera.wheel_step));  // 100: a notch's deltaY
      if (!playing) frame();
    }, { passive: false });
  }

  let frames = 0;
  let since = performance.now();
  let last = null;
  function tick(now) {
    const elapsed = last === null ? 0 : (now - last) / 1000;
    last = now;
    if (playing) {
      nextFrame(stepsFor(elapsed));
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
    // The next n frames of the run (each its uniforms, its steps and its draw), as
    // Pipeline.frames makes them; returns the frame drawn last.
    frames(n = 1) {
      for (let i = 0; i < n; i += 1) nextFrame();
      gl.finish();
      return frameIndex;
    },
    // Frames played after each of these many seconds of the clock (tests pass their own):
    // the steps each ran.
    play(seconds) {
      const steps = seconds.map((elapsed) => nextFrame(stepsFor(elapsed)));
      gl.finish();
      return steps;
    },
    // Run n steps, drawing a frame after the last; returns the steps done so far.
    step(n = 1) {
      for (let i = 0; i < n; i += 1) step();
      frame();
      gl.finish();
      return stepsDone;
    },
    pause() { playing = false; label(); },
    // Turn the camera about its target by a drag of (dx, dy) pixels, or move it nearer (factor
    // below 1) or farther, then draw the frame again.
    orbit(dx, dy) { camera.orbit(dx, dy); frame(); gl.finish(); },
    zoom(factor) { camera.zoom(factor); frame(); gl.finish(); },
    // The grip's rest centre as the hand has put it, and the camera's eye now (tests).
    grip() { return grip ? grip.centre.slice() : null; },
    // Where the ray through pixel (x, y) of the picture meets the grip, or null.
    pick(x, y) { return grip ? grip.hit(...camera.ray(x, y)) : null; },
    eye() { return camera ? camera.eye() : null; },
    // The raw RGBA8 texels of a quantity's part (front texture), width x height, base64.
    state(name, part = 0) {
      if (plan.resources[name] === undefined || plan.resources[name].kind !== "state") {
        fail(`state(${name}): the plan's quantities are ` + Object.keys(plan.resources)
          .filter((n) => plan.resources[n].kind === "state").join(", "));
      }
      return base64(read(front(name, part), gl.UNSIGNED_BYTE, Uint8Array));
    },
    // Replace a quantity's part (front texture) with RGBA8 texels, width x height, base64: a
    // test loads the EGL run's state to compare the drawing alone.
    load(name, part, texels) {
      const t = front(name, part);
      gl.bindTexture(gl.TEXTURE_2D, t.texture);
      gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, t.width, t.height, gl.RGBA, gl.UNSIGNED_BYTE,
                       bytes(texels));
    },
    // Draw the frame again (the camera or a loaded state changed), as after `steps` steps if
    // given (the step number the passes and a moving object's pose follow).
    frame(steps) {
      if (steps !== undefined) stepsDone = steps;
      frame();
      gl.finish();
    },
    // A target's latest texels (RGBA8 as bytes, float formats as float32), base64.
    resource(name, part = 0) {
      const t = front(name, part);
      return t.type === gl.UNSIGNED_BYTE ? base64(read(t, gl.UNSIGNED_BYTE, Uint8Array))
        : base64(read(t, gl.FLOAT, Float32Array));
    },
    // The last frame's density, float32 per pixel (bottom row first), base64, and the pixels a
    // batch channel filled to its top (where the count may be short).
    density() {
      const out = new Float32Array(width * height);
      let flagged = 0;
      if (path === "float") {
        const raw = read(densityTexture, gl.FLOAT, Float32Array);
        for (let i = 0; i < out.length; i += 1) out[i] = raw[4 * i];
      } else {
        const raw = read(densityTexture, gl.UNSIGNED_BYTE, Uint8Array);
        const unit = plan.density.intensity / levels;
        for (let i = 0; i < out.length; i += 1) {
          out[i] = (raw[4 * i] + 256 * raw[4 * i + 1] + 65536 * raw[4 * i + 2]) * unit;
          if (raw[4 * i + 3] > 0) flagged += 1;
        }
      }
      return { values: base64(out), flagged };
    },
    // The last frame's image (RGBA8, bottom row first), base64.
    image() { return base64(read(front(plan.present), gl.UNSIGNED_BYTE, Uint8Array)); },
  };
  document.body.dataset.ready = "yes";
}());
