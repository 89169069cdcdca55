"""The fast paths compute what the plain ones do: sparse products without scipy's
dispatch, actions-first value iteration, shared gap columns, the sparse meeting matrix, and the
factored equilibrium weighing (exact when no meeting is possible)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse import _sparsetools

from mirl.learning.equilibria import (
    _robot_steps,
    factored_log_likelihood,
    joint_log_likelihood,
    meeting_matrix,
)
from mirl.learning.sequence import ObservedSequence
from mirl.learning.soft_policy import _Dynamics
from mirl.mdp import TabularMDP, greedy_policy, value_iteration
from mirl.simulation.grid import simulate
from mirl.sparse import csc_block_matvec, csr_block_matvec, csr_matmul
from mirl.world.game import meeting
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def boyd2():
    return load_scenario("boyd2")


def test_csr_matmul_is_bitwise_the_sparse_product():
    rng = np.random.default_rng(0)
    A = sp.random_array((50, 40), density=0.1, random_state=1, format="csr")
    for X in (rng.random(40), rng.random((40, 3)), rng.random((3, 40)).T):
        assert np.array_equal(csr_matmul(A, X), A @ X)


@pytest.mark.parametrize("width", [1, 3])
def test_block_matvecs_are_bitwise_the_block_kernels(width):
    """The kernels the gap filter and its adjoint call (scipy's one-vector kernel for one
    column) give bitwise what scipy's block kernels and ``@`` give, adding into a block that is
    not zero as well as into zeros."""
    rng = np.random.default_rng(width)
    A = sp.random_array((300, 300), density=0.02, random_state=2, format="csr")
    A.data = rng.random(A.nnz) * 1e-3  # values whose sums round
    X, Y0 = rng.random((300, width)), rng.random((300, width))
    At = sp.csc_array(A.T)  # Aᵀ as CSC: the arrays of A's CSR, read transposed
    for fn, block, M, product in (
        (csr_block_matvec, _sparsetools.csr_matvecs, A, A @ X),
        (csc_block_matvec, _sparsetools.csc_matvecs, At, At @ X),
    ):
        arrays = (M.indptr, M.indices, M.data, X.ravel())
        ours, theirs = Y0.copy(), Y0.copy()
        fn(300, 300, width, *arrays, ours.reshape(-1))
        block(300, 300, width, *arrays, theirs.reshape(-1))
        assert np.array_equal(ours, theirs)
        Z = np.zeros((300, width))
        fn(300, 300, width, *arrays, Z.reshape(-1))
        assert np.array_equal(Z, product)


@pytest.mark.parametrize("n_actions", [1, 2, 3, 4, 5, 7, 8, 9])
def test_row_sums_and_softmax_are_bitwise_numpys(n_actions):
    """Sums and softmax over a few actions, a column at a time, equal numpy's reductions along
    the short axis bit for bit — on rows built so that the order of a sum or the sign of a zero
    would show."""
    from mirl.learning.soft_policy import _row_sum, _softmax

    rng = np.random.default_rng(n_actions)
    X = rng.normal(size=(500, n_actions)) * 10.0 ** rng.integers(-8, 17, size=(500, n_actions))
    X[:5, :3] = [1e16, 1.0, -1e16][:n_actions]  # left to right: 0; other groupings are not
    X[5] = -0.0  # numpy sums from +0.0
    X[6, :2] = [-0.0, 0.0][:n_actions]
    X[7] = 0.0
    X[8] = X[8, 0]  # ties
    assert np.array_equal(_row_sum(X), X.sum(axis=1))
    assert np.array_equal(np.signbit(_row_sum(X)), np.signbit(X.sum(axis=1)))

    def softmax_as_before(Q, temperature):
        m = Q.max(axis=1)
        z = np.exp((Q - m[:, None]) / temperature)
        tot = z.sum(axis=1)
        return z / tot[:, None], m + temperature * np.log(tot)

    Q = np.clip(X, -700, 700)  # no overflow of exp: these are Q values, not arbitrary reals
    for temperature in (1.0, 0.3):
        pairs = zip(_softmax(Q, temperature), softmax_as_before(Q, temperature), strict=True)
        for ours, theirs in pairs:
            assert np.array_equal(ours, theirs)
            assert np.array_equal(np.signbit(ours), np.signbit(theirs))


def test_actions_first_value_iteration_is_bitwise_the_plain_one(boyd2):
    T = boyd2.true_transitions(1)
    R = boyd2.domain.rewards(boyd2.robots[1].weights)
    mdp = TabularMDP(T, R, 0.95)
    V = np.zeros(mdp.n_states)
    for _ in range(10_000):  # the textbook loop over the (S, A) layout
        Q = mdp.rewards + mdp.discount * (mdp.transitions @ V).reshape(R.shape)
        V_new = Q.max(axis=1)
        done = np.abs(V_new - V).max() < 1e-8
        V = V_new
        if done:
            break
    res = value_iteration(mdp)
    assert np.array_equal(res.values, V)
    assert np.array_equal(res.q_values, Q)
    assert np.array_equal(res.policy, greedy_policy(Q))


def test_shared_gap_columns_give_the_per_gap_likelihood(boyd2):
    d = boyd2.domain
    obs = simulate(boyd2, 300, seed=3, observability=0.14, random_starts=True).observations
    x = obs.state_series(d, 0)
    vis = d.visible_states(0.14) | np.isin(np.arange(d.n_states), x[x >= 0])
    T = boyd2.true_transitions(0)
    dyn = _Dynamics(T, d.n_actions)
    seq = ObservedSequence(x, np.ones(len(x), bool), dyn, d.n_states)
    assert len(seq._col_need) < seq._gap_U0.shape[1]  # columns were shared
    pi = np.full((d.n_states, d.n_actions), 1.0 / d.n_actions)
    PT = dyn.transposed_policy(pi)
    ll, _ = seq.loglik(pi, PT, vis)
    # reference: every gap on its own, dense, no rescaling
    P = PT.toarray()
    ref = float(np.log((pi[seq._pair[0]] * seq._Tab).sum(axis=1)).sum())
    for g in range(seq._gap_U0.shape[1]):
        z = seq._gap_U0[:, g].copy()
        for _ in range(seq._gap_steps[g]):
            z = P @ z
            if seq._gap_ends[g] < 0 or _ + 1 < seq._gap_steps[g]:
                z = z * ~vis
        ref += np.log(z[seq._gap_ends[g]] if seq._gap_ends[g] >= 0 else z.sum())
    assert ll == pytest.approx(ref, rel=1e-9)


def test_sparse_meeting_matrix_is_the_dense_rule(boyd2):
    d = boyd2.domain
    pol = [boyd2.true_policy(0), boyd2.true_policy(1)]
    S = d.n_states
    si, sj = np.divmod(np.arange(S * S), S)
    dense = meeting(d, si, sj, pol[0][si], pol[1][sj]).reshape(S, S)
    assert dense.any()
    assert np.array_equal(meeting_matrix(d, pol[0], pol[1]).toarray() > 0, dense)


def test_factored_weighing_is_exact_without_meetings_and_close_with_them(boyd2):
    d = boyd2.domain
    obs = simulate(boyd2, 300, seed=1, observability=0.14, random_starts=True).observations
    series = [obs.state_series(d, i) for i in range(2)]
    pol = [boyd2.true_policy(0), boyd2.true_policy(1)]
    T = [boyd2.true_transitions(0), boyd2.true_transitions(1)]
    vis = d.visible_states(0.14).copy()
    for s in series:
        vis[s[s >= 0]] = True
    eqs = boyd2.game.equilibria()
    PT, GT = _robot_steps(d, pol, T, eqs[0], 1e-3)
    # no meeting matrix: two independent filters, whose likelihoods multiply
    none = factored_log_likelihood(series, PT, GT, sp.csr_array((d.n_states, d.n_states)), vis)
    single = 0.0
    for k, s in enumerate(series):
        b = np.full(d.n_states, 1.0 / d.n_states)
        for t in range(len(s)):
            if t:
                b = PT[k] @ b
            b = np.where(np.arange(d.n_states) == s[t], b, 0) if s[t] >= 0 else b * ~vis
            single += np.log(b.sum())
            b /= b.sum()
    assert none == pytest.approx(single, rel=1e-10)
    exact = [joint_log_likelihood(d, series, pol, T, e, vis, max_joint_states=None) for e in eqs]
    approx = [joint_log_likelihood(d, series, pol, T, e, vis, max_joint_states=0) for e in eqs]
    assert int(np.argmax(exact)) == int(np.argmax(approx))
    assert np.abs(np.subtract(exact, approx)).max() < 3.0  # measured 0.2-1.4 (docs/design.md)


def test_meeting_part_of_the_joint_step_is_bitwise_the_dense_product(boyd2):
    from mirl.learning.equilibria import _joint_filter

    d = boyd2.domain
    pol = [boyd2.true_policy(0), boyd2.true_policy(1)]
    T = [boyd2.true_transitions(0), boyd2.true_transitions(1)]
    for eq in boyd2.game.equilibria():
        jf = _joint_filter(d, pol, T, eq, 1e-3)
        PT, GT = _robot_steps(d, pol, T, eq, 1e-3)
        M = np.random.default_rng(0).random((d.n_states, d.n_states))
        at = np.where(jf._off == 0.0, M, 0.0)
        dense = csr_matmul(PT[0], csr_matmul(PT[1], (M - at).T).T) + csr_matmul(
            GT[0], csr_matmul(GT[1], at.T).T
        )
        assert (jf._off == 0.0).any()
        assert np.array_equal(jf.step(M, -1, -1), dense)


@pytest.mark.parametrize(("name", "degree"), [("boyd2", 0.14), ("boyd2", 1.0), ("boydright", 0.5)])
def test_joint_filter_is_bitwise_the_plain_one(name, degree):
    """The joint filter's shortcuts (outer products after a robot was seen, the meeting part as
    fixed linear maps) give the log-likelihood of the plain filter bit for bit, for every
    candidate equilibrium, with learned (not true) models."""
    from mirl.learning.learn import learn
    from tests.references.joint_filter import reference_joint_log_likelihood

    sc = load_scenario(name)
    d = sc.domain
    obs = simulate(sc, 200, seed=1, observability=degree, random_starts=True).observations
    series = [obs.state_series(d, i) for i in range(2)]
    assert all((s >= 0).any() for s in series)  # both robots' shortcuts are taken
    res = learn(obs, sc, "mirl", observability=degree, score=False)
    pol, T = [r.policy for r in res.robots], [r.transitions for r in res.robots]
    vis = d.visible_states(degree)
    for e in sc.game.equilibria():
        ours = joint_log_likelihood(d, series, pol, T, e, vis, max_joint_states=None)
        assert ours == reference_joint_log_likelihood(d, series, pol, T, e, vis)


def test_forward_operator_pattern_reuse_and_direct_lapack_solve_are_bitwise(boyd2):
    import scipy.linalg as sla

    from mirl.learning.sequence import BlockOperator, _block_operator
    from mirl.learning.soft_policy import _dense_solve

    d = boyd2.domain
    T = boyd2.true_transitions(1)
    forward_operator = BlockOperator()  # one per fit in OccludedMaxEntIRL
    dyn = _Dynamics(T, d.n_actions)
    rng = np.random.default_rng(1)
    for _ in range(2):  # the second call reuses the pattern built by the first
        pi = rng.dirichlet(np.ones(d.n_actions), size=d.n_states)
        dpi = rng.normal(size=(d.n_states, d.n_actions, 3))
        PT, dPT = dyn.transposed_policy(pi), dyn.transposed_policy(dpi)
        got, ref = forward_operator(PT, dPT), _block_operator(PT, dPT)
        assert np.array_equal(got.indptr, ref.indptr)
        assert np.array_equal(got.indices, ref.indices)
        assert np.array_equal(got.data, ref.data)
        M = np.eye(d.n_states) - 0.95 * dyn.policy_matrix(pi)
        b = rng.normal(size=(d.n_states, 3))
        assert np.array_equal(_dense_solve(M, b), sla.solve(M, b, check_finite=False))
        assert np.array_equal(_dense_solve(M, b[:, 0]), sla.solve(M, b[:, 0], check_finite=False))


def test_sparse_transition_lookup_is_the_dense_rows():
    """On a large model T(s, ·, s') is looked up entry by entry: the values of densified rows."""
    sc = load_scenario("office")
    T = sc.true_transitions(1)
    dyn = _Dynamics(T, sc.domain.n_actions)
    assert dyn.dense is None  # the sparse path
    rng = np.random.default_rng(0)
    pick = rng.choice(T.nnz, 300, replace=False)  # real transitions, so most values are > 0
    rows = np.repeat(np.arange(T.shape[0]), np.diff(T.indptr))[pick]
    s, s_next = rows // dyn.A, T.indices[pick]
    dense = T[(s[:, None] * dyn.A + np.arange(dyn.A)).ravel()].toarray()
    expected = dense.reshape(len(s), dyn.A, dyn.S)[np.arange(len(s)), :, s_next]
    assert np.array_equal(dyn.transition_values(s, s_next), expected)
    assert (expected > 0).sum() >= 300


def test_policy_system_is_scipys_matrix_value_for_value():
    """I − γP_π gathered into a fixed pattern is the CSC array scipy makes of eye − γ·P_π, every
    value in the same place (office T, smooth and peaked soft policies)."""
    from mirl.learning.soft_policy import _PolicySystem

    sc = load_scenario("office")
    rng = np.random.default_rng(5)
    for robot in (0, 2):
        dyn = _Dynamics(sc.true_transitions(robot), sc.domain.n_actions)
        system = _PolicySystem(dyn.T, dyn.rows, dyn.A)
        for scale in (1.0, 30.0):
            Q = rng.normal(scale=scale, size=(dyn.S, dyn.A))
            pi = np.exp(Q - Q.max(axis=1, keepdims=True))
            pi /= pi.sum(axis=1, keepdims=True)
            expected = sp.csc_array(sp.eye_array(dyn.S) - 0.95 * dyn.policy_matrix(pi))
            got = system.matrix(pi, 0.95)
            assert got is not None
            for field in ("indptr", "indices", "data"):
                assert np.array_equal(getattr(got, field), getattr(expected, field))
        b = rng.random(dyn.S)
        assert np.array_equal(
            dyn.solve_policy(pi, 0.95, b), dyn.solve(dyn.policy_matrix(pi), 0.95, b)
        )


def test_policy_system_on_random_models_and_exact_zeros():
    """Random sparse T (successors differ by action): the same values as scipy's; where an
    action of probability exactly 0 leaves an entry at 0, scipy drops it and so does the
    fallback (None)."""
    from mirl.learning.soft_policy import _policy_matrix, _PolicySystem

    rng = np.random.default_rng(8)
    S, A = 40, 3
    T = sp.random_array((S * A, S), density=0.08, random_state=2, format="csr")
    some = sp.csr_array((np.ones(S * A), (np.arange(S * A), np.arange(S * A) % S)))
    T = sp.csr_array(T + some)  # every (s, a) goes somewhere
    T = sp.csr_array(T.multiply(1.0 / T.sum(axis=1)[:, None]))
    rows = np.repeat(np.arange(S * A), np.diff(T.indptr))
    system = _PolicySystem(T, rows, A)
    pi = rng.dirichlet(np.ones(A), size=S)
    expected = sp.csc_array(sp.eye_array(S) - 0.9 * _policy_matrix(T, rows, pi, S))
    got = system.matrix(pi, 0.9)
    assert got is not None
    for field in ("indptr", "indices", "data"):
        assert np.array_equal(getattr(got, field), getattr(expected, field))
    pi[:, 1:] = 0.0
    pi[:, 0] = 1.0
    assert sp.csc_array(sp.eye_array(S) - 0.9 * _policy_matrix(T, rows, pi, S)).nnz < got.nnz
    assert system.matrix(pi, 0.9) is None


def test_policy_system_solves_in_its_first_column_order():
    """Later solves reuse the first factorisation's column order (NATURAL on the reordered
    matrix): bitwise scipy's ``splu(matrix).solve`` for smooth and moderately peaked policies
    (one and several right-hand sides); for near-deterministic ones a column can hold tied
    pivot candidates, which the two ways may break differently: equal to round-off there."""
    import scipy.sparse.linalg as spla

    from mirl.learning.soft_policy import _PolicySystem

    sc = load_scenario("office")
    rng = np.random.default_rng(11)
    for robot in (1, 3):
        dyn = _Dynamics(sc.true_transitions(robot), sc.domain.n_actions)
        system = _PolicySystem(dyn.T, dyn.rows, dyn.A)
        for k, scale in enumerate((1.0, 30.0, 3.0, 10.0, 100.0, 1000.0)):
            Q = rng.normal(scale=scale, size=(dyn.S, dyn.A))
            pi = np.exp(Q - Q.max(axis=1, keepdims=True))
            pi /= pi.sum(axis=1, keepdims=True)
            b = rng.normal(size=(dyn.S, 3)) if k % 2 else rng.normal(size=dyn.S)
            expected = spla.splu(system.matrix(pi, 0.95)).solve(b)
            if scale <= 30.0:
                assert np.array_equal(system.solve(pi, 0.95, b), expected)
            else:
                np.testing.assert_allclose(system.solve(pi, 0.95, b), expected, rtol=0, atol=1e-12)
        assert system.ordering is not None  # later solves took the ordered way
        assert not np.array_equal(system.ordering[0], np.arange(dyn.S))


@pytest.mark.parametrize("max_joint_states", [None, 0])  # exact and factored
def test_unseen_where_every_state_is_visible_is_no_evidence(boyd2, max_joint_states):
    """A camera that misses a robot at full view (physics: an occluded or off-map pose) gives
    an observation impossible from any state; the weighing must stay finite and ignore it."""
    d = boyd2.domain
    obs = simulate(boyd2, 60, seed=1, observability=1.0, random_starts=True).observations
    series = [obs.state_series(d, i) for i in range(2)]
    pol = [boyd2.true_policy(0), boyd2.true_policy(1)]
    T = [boyd2.true_transitions(0), boyd2.true_transitions(1)]
    vis = np.ones(d.n_states, dtype=bool)
    missed = [s.copy() for s in series]
    missed[1][30:33] = -1
    for e in boyd2.game.equilibria():
        full = joint_log_likelihood(d, series, pol, T, e, vis, max_joint_states=max_joint_states)
        gap = joint_log_likelihood(d, missed, pol, T, e, vis, max_joint_states=max_joint_states)
        assert np.isfinite(full) and np.isfinite(gap)
