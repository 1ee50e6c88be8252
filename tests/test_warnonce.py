"""Each warning once per run (``robolobes.core.warnonce``)."""

import warnings

from robolobes.core.warnonce import each_warning_once


def _warn_from_two_places(text):
    warnings.warn(text, UserWarning, stacklevel=1)  # first call site


def _warn_again(text):
    warnings.warn(text, UserWarning, stacklevel=1)  # a second call site, same text


def _shown(block):
    """Messages that reach showwarning while ``block()`` runs under the "always" filter."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        block()
    return [str(w.message) for w in caught]


def test_repeated_warning_is_shown_once_even_across_catch_warnings_blocks():
    def run():
        with each_warning_once():
            _warn_from_two_places("joint A3 past its limit")
            with warnings.catch_warnings():  # resets Python's own once-per-location memory
                warnings.simplefilter("ignore", DeprecationWarning)
            _warn_again("joint A3 past its limit")
            _warn_from_two_places("joint A3 past its limit")

    assert _shown(run) == ["joint A3 past its limit"]


def test_without_the_wrapper_the_same_warning_is_shown_every_time():
    # the control: what the wrapper removes is really there
    def run():
        _warn_from_two_places("joint A3 past its limit")
        _warn_again("joint A3 past its limit")

    assert _shown(run) == ["joint A3 past its limit"] * 2


def test_different_texts_and_categories_are_each_shown():
    def run():
        with each_warning_once():
            warnings.warn("a", UserWarning, stacklevel=1)
            warnings.warn("b", UserWarning, stacklevel=1)
            warnings.warn("a", RuntimeWarning, stacklevel=1)
            warnings.warn("b", UserWarning, stacklevel=1)

    assert _shown(run) == ["a", "b", "a"]


def test_each_run_shows_its_own_warnings_and_the_hook_is_restored():
    before = warnings.showwarning

    def run():
        for _ in range(2):
            with each_warning_once():
                warnings.warn("once per run", UserWarning, stacklevel=1)
                warnings.warn("once per run", UserWarning, stacklevel=1)

    assert _shown(run) == ["once per run"] * 2
    assert warnings.showwarning is before


def test_ignored_warnings_stay_ignored():
    def run():
        with each_warning_once():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                warnings.warn("silenced", UserWarning, stacklevel=1)
            warnings.warn("shown", UserWarning, stacklevel=1)

    assert _shown(run) == ["shown"]
