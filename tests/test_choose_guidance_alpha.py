"""scripts/choose_guidance_alpha.py: the step sizes it tries go outwards until the best is bracketed."""
from helpers import load_script

script = load_script("choose_guidance_alpha")
GRID = (0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0)


def test_it_goes_outwards_until_a_worse_alpha_lies_on_each_side():
    assert script.next_alpha({10.0, 30.0, 100.0}, 30.0, GRID) is None            # bracketed
    assert script.next_alpha({10.0, 30.0, 100.0}, 10.0, GRID) == 3.0             # best at the low end: go lower
    assert script.next_alpha({10.0, 30.0, 100.0}, 100.0, GRID) == 300.0          # at the high end: go higher
    assert script.next_alpha({0.3, 1.0, 3.0}, 0.3, GRID) is None                 # the grid runs out
    assert script.next_alpha({100.0, 300.0}, 300.0, GRID) is None


def test_it_starts_from_the_librarys_step_sizes_on_its_grid():
    from hoi_tutorial.nifty import evaluation, guidance

    assert script.evaluation.ALPHA_GRID == evaluation.ALPHA_GRID
    assert all(alpha in evaluation.ALPHA_GRID for alpha in guidance.GUIDANCE_ALPHA.values())
