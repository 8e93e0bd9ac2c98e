"""CHOICE Fig. 11's latent map: the codes fitted in unseen layouts, embedded with the training codes."""
import numpy as np
import pytest

from hoi_tutorial.choice.planner import interactions, intp, latent_map, table3


@pytest.fixture(scope="module")
def tiny(module_cache):
    """Two training clips, two test clips, a small auto-decoder, and their latent map (perplexity 3: few codes)."""
    data_config = interactions.planner_data_config("toy", n_clips=2, n_test_clips=2)
    config = intp.planner_config("toy", width=48, latent=8, steps=300, batch_size=4, fit_steps=30)
    return data_config, config, latent_map.latent_map(data_config, config, seed=0, perplexity=3.0)


def test_the_map_holds_the_planners_codes_and_the_fits_it_plans_with(tiny):
    data_config, config, mapped = tiny
    model = intp.trained_planner(data_config, config).model
    train = interactions.interaction_set(data_config, "train")
    test = interactions.interaction_set(data_config, "test")
    cases = table3.planning_cases(test, data_config.field, reshape=False, seed=0)
    direct = np.stack([intp.plan_each_init(model, config, train, c.scene, c.condition, c.start, c.goal)[0].code.numpy()
                       for c in cases])
    np.testing.assert_array_equal(mapped.codes, model.codes.weight.detach().numpy())
    np.testing.assert_array_equal(mapped.fitted, direct)  # the best initialisation's code, as plan_each_init plans
    np.testing.assert_array_equal(mapped.sources, [c.source for c in cases])
    np.testing.assert_array_equal(mapped.conditions, np.stack([c.condition for c in cases]).astype(np.float32))
    assert mapped.embedded.shape == (len(mapped.codes) + len(cases), 2)
    assert np.isfinite(mapped.embedded).all() and mapped.embedded.std(axis=0).min() > 0


def test_the_map_is_computed_once_then_loaded(tiny, module_cache):
    data_config, config, mapped = tiny
    assert len(list(module_cache.glob("choice_latent_map-*.pt"))) == 1
    again = latent_map.latent_map(data_config, config, seed=0, perplexity=3.0)
    for name in ("codes", "fitted", "embedded", "sources", "conditions"):
        np.testing.assert_array_equal(getattr(again, name), getattr(mapped, name))
    assert again.seconds == mapped.seconds  # what the build measured, not a second build
    assert len(list(module_cache.glob("choice_latent_map-*.pt"))) == 1


def test_a_perplexity_that_is_not_positive_is_refused(tiny):
    data_config, config, _ = tiny
    with pytest.raises(ValueError, match="perplexity: expected a positive number"):
        latent_map.latent_map(data_config, config, perplexity=0)
