"""The discrete PID against its transfer function evaluated by python-control."""

import control
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from ltdsim.physics import pid_init, pid_step
from ltdsim.physics.control import BACKWARD_EULER, FORWARD_EULER


def transfer_function(kp, ki, kd, n, ts, integrator, filt):
    z = control.tf([1.0, 0.0], [1.0], ts)  # the shift operator z, sample time ts
    f_i = ts / (z - 1) if integrator == FORWARD_EULER else ts * z / (z - 1)
    f_d = ts / (z - 1) if filt == FORWARD_EULER else ts * z / (z - 1)
    return kp + ki * f_i + kd * n / (1 + n * f_d)


def respond(error, kp, ki, kd, n, ts, integrator, filt):
    state = pid_init()
    return np.array([pid_step(e, state, kp, ki, kd, n, ts, integrator, filt) for e in error])


METHODS = [(FORWARD_EULER, BACKWARD_EULER), (FORWARD_EULER, FORWARD_EULER),
           (BACKWARD_EULER, BACKWARD_EULER), (BACKWARD_EULER, FORWARD_EULER)]


@pytest.mark.parametrize("integrator,filt", METHODS)
def test_step_response_of_the_study_pid_equals_its_transfer_function(integrator, filt):
    # case LHHL gains (Table 2), N = 100, Ts = 1e-4 s
    kp, ki, kd, n, ts = 31.22, 16.244, 0.0175, 100.0, 1e-4
    steps = 400
    u = np.ones(steps)
    t = np.arange(steps) * ts
    expected = control.forced_response(transfer_function(kp, ki, kd, n, ts, integrator, filt),
                                       T=t, U=u).outputs
    assert_allclose(respond(u, kp, ki, kd, n, ts, integrator, filt), expected, rtol=1e-9,
                    atol=1e-12)


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")  # python-control, kp = 0
@settings(max_examples=25, deadline=None)
@given(kp=st.floats(0.0, 100.0, allow_subnormal=False),
       ki=st.floats(0.0, 50.0, allow_subnormal=False),
       kd=st.one_of(st.just(0.0), st.floats(1e-6, 0.1)), n=st.floats(1.0, 1000.0), ts=st.sampled_from([1e-4, 1e-3, 1e-2]),
       seed=st.integers(0, 2**31 - 1), methods=st.sampled_from(METHODS))
def test_pid_response_to_any_error_sequence_equals_the_transfer_function(kp, ki, kd, n, ts, seed,
                                                                         methods):
    integrator, filt = methods
    assume(n * ts <= 1.0)  # a discrete derivative filter is used well inside its stable range
    rng = np.random.default_rng(seed)
    u = rng.normal(size=200)
    t = np.arange(u.size) * ts
    expected = control.forced_response(transfer_function(kp, ki, kd, n, ts, integrator, filt),
                                       T=t, U=u).outputs
    got = respond(u, kp, ki, kd, n, ts, integrator, filt)
    assert_allclose(got, expected, rtol=1e-8, atol=1e-9 * (1 + np.abs(expected).max()))
