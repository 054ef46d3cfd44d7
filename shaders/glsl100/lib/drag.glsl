// Linear drag, v' = a - k v, integrated exactly over a step h (stable for any k h): the velocity
// after the step is v * decay + a * gain, with (decay, gain) = exact_drag(k, h); below k h = 1e-3
// the gain's first-order form avoids dividing by a vanishing k. numpy twin: twins/drag.py.

vec2 exact_drag(float k, float h)
{
    float kh = k * h;
    float decay = exp(-kh);
    return vec2(decay, (kh < 1e-3) ? h * (1.0 - 0.5 * kh) : (1.0 - decay) / k);
}
