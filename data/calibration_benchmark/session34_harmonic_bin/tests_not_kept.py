

def test_a_line_at_a_harmonic_beyond_the_guarded_ones_is_refused_as_unresolvable():
    """5·f0 exactly, beyond the guard's K = 3 harmonics: a function of the motion's phase has lines at
    every multiple of f0 (a Coulomb shape error on a sinusoid has 3ω, 5ω, 7ω, …), and within one
    frequency bin the record cannot resolve a time line from it, whatever the harmonic's order
    (session 34; until then a line at 5·f0 was named). Reported as not decided by the record."""
    v, f0 = _sinusoid()
    k = PHASE_HARMONICS + 2
    res = _run(_record(v, _line(k, f0)))
    assert "time_periodic" not in [a.kind for a in res.accepted]
    reasons = [r["reason"] for r in res.rejected if r["kind"] == "time_periodic"]
    assert any("within one frequency bin" in r and f"harmonic {k}" in r for r in reasons), reasons
    assert "time_periodic" in [u["kind"] for u in res.undecided]


def test_a_line_between_two_harmonics_beyond_the_guarded_ones_is_named_at_its_frequency():
    """5.5·f0: 2.5 bins from both neighbours (f0 is 5 bins on this 5-cycle record), so resolved."""
    v, f0 = _sinusoid()
    f_line = 5.5 * f0
    res = _run(_record(v, lambda t, q: 0.5 * np.sin(2 * math.pi * f_line * t)))
    assert "time_periodic" in [a.kind for a in res.accepted]
    assert any(abs(f - f_line) / f_line < 0.01 for f in res.final.spec.time_frequencies)
