// What the calibrated display is asked to show, drawn with WebGL2 (an ES
// module shared by the experiment's session page and the stimulus-set
// page): linear RGB (a float texture) through the display profile's inverse
// (drive = linear^(1/γ) per gun) and then the output method:
//  - 8bit: the nearest 8-bit code;
//  - noisy_bit: noisy-bit dithering (Allard & Faubert 2008): each pixel and
//    frame shows the upper of the two 8-bit codes around the fractional
//    code with probability equal to its fraction;
//  - 10bit, 12bit: the nearest 10- or 12-bit code, written as a fraction of
//    full drive: a float16 drawing buffer keeps 10 bits; an 8-bit canvas
//    shows the nearest 8-bit code of it (the page says which it has).

export const METHOD = { "8bit": 0, "noisy_bit": 1, "10bit": 2, "12bit": 3 };

export const VERTEX = `#version 300 es
in vec2 position;
void main() { gl_Position = vec4(position, 0.0, 1.0); }`;

/** GLSL (after `#version` and the precision lines): the uniforms
 * `inverseGamma` (1/γ of red, green, blue), `method` (METHOD) and
 * `frameSeed`, and `vec3 shown(vec3 linear, ivec2 p)`: the drive the
 * display gets for linear RGB at pixel p. */
export const OUTPUT_GLSL = `
uniform vec3 inverseGamma;
uniform int method;
uniform uint frameSeed;

// A 32-bit integer hash (PCG's output permutation): a fresh uniform number
// per pixel, channel and frame.
uint hash(uint v) {
  uint state = v * 747796405u + 2891336453u;
  uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}
float uniform01(uint v) { return (float(hash(v) >> 8u) + 0.5) / 16777216.0; }

vec3 shown(vec3 linear, ivec2 p) {
  vec3 drive = pow(clamp(linear, 0.0, 1.0), inverseGamma);
  if (method == 1) {
    vec3 code = drive * 255.0;
    vec3 low = min(floor(code), vec3(254.0));
    vec3 fraction = code - low;
    uint pixel = hash(uint(p.x) ^ hash(uint(p.y) ^ hash(frameSeed)));
    vec3 r = vec3(uniform01(pixel), uniform01(pixel ^ 0x9E3779B9u), uniform01(pixel ^ 0x7F4A7C15u));
    return (low + vec3(lessThan(r, fraction))) / 255.0;
  } else if (method == 2) {
    return floor(drive * 1023.0 + 0.5) / 1023.0;
  } else if (method == 3) {
    return floor(drive * 4095.0 + 0.5) / 4095.0;
  }
  return floor(drive * 255.0 + 0.5) / 255.0;
}`;

export function compile(gl, type, source) {
  const s = gl.createShader(type);
  gl.shaderSource(s, source);
  gl.compileShader(s);
  if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error("shader: " + gl.getShaderInfoLog(s));
  return s;
}

/** Links VERTEX with `fragment`, uses it, and binds a triangle that covers
 * the canvas to its `position`; the program. */
export function fullScreenProgram(gl, fragment) {
  const program = gl.createProgram();
  gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, VERTEX));
  gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, fragment));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error("shader program: " + gl.getProgramInfoLog(program));
  gl.useProgram(program);
  const buffer = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
  const loc = gl.getAttribLocation(program, "position");
  gl.enableVertexAttribArray(loc);
  gl.vertexAttribPointer(loc, 2, gl.FLOAT, false, 0, 0);
  return program;
}

/** A texture sampled texel by texel (no filtering, no wrapping). */
export function nearestTexture(gl) {
  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  for (const [k, v] of [[gl.TEXTURE_MIN_FILTER, gl.NEAREST], [gl.TEXTURE_MAG_FILTER, gl.NEAREST],
    [gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE], [gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE]]) gl.texParameteri(gl.TEXTURE_2D, k, v);
  return texture;
}
