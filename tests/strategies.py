"""Hypothesis strategies shared by the tests."""
from hypothesis import strategies as st


def paper_table_designs(mu=None):
    """(l1, l2, r1, r2, w, r, mu) on the paper's table (MODEL 1), by integer index (no float
    accumulation); `mu` replaces the table's friction values with another strategy."""
    return st.tuples(
        st.integers(0, 8).map(lambda i: 0.4 + i * 0.2),       # l1
        st.integers(0, 3).map(lambda i: 0.4 + i * 0.4),       # l2
        st.integers(0, 4).map(lambda i: 0.04 + i * 0.04),     # r1
        st.integers(0, 4).map(lambda i: 0.02 + i * 0.04),     # r2
        st.integers(0, 5).map(lambda i: 0.0 + i * 0.4),       # w
        st.integers(0, 3).map(lambda i: 0.4 + i * 0.4),       # r
        st.integers(0, 3).map(lambda i: 0.1 + i * 0.3) if mu is None else mu,  # mu
    )
