"""The particle filter's predictor (phases 1-2, eqs. 5-11): the people-motion and ego-motion models in sampling form,
the births at the grid's border and the empty cells' prior, in a reference (numpy) and a compiled form.

=================================  ==================================================================================
module                             what it holds
=================================  ==================================================================================
:mod:`.protocols`                  :class:`PeopleSampler`, :class:`EgoSampler`: what a model is (and its forms)
:mod:`.paper`                      :class:`PaperSampling`: the paper's memoryless people motion (eqs. 5-9)
:mod:`.persistent`                 :class:`PersistentSampling`: walkers keep heading and speed
:mod:`.ego`                        :class:`VelocityEgoSampling`: the sensor motion (eqs. 10-11)
:mod:`.births`                     newborn particles: the border's inflow, the motion prior's velocities
:mod:`.empty_cells`                the prior of the cells without a particle (the grid's linear prediction)
:mod:`.reference`, :mod:`.compiled`  the prediction of a filter step in numpy, compiled
:mod:`.passes`, :mod:`.draws`      the compiled passes shared by every model; the random draws inside kernels
=================================  ==================================================================================
"""

from pfpeople.particle.predictor.ego import VelocityEgoSampling
from pfpeople.particle.predictor.paper import PaperSampling
from pfpeople.particle.predictor.persistent import PersistentMotion, PersistentSampling
from pfpeople.particle.predictor.protocols import EgoSampler, PeopleSampler

__all__ = [
    "PEOPLE_SAMPLERS",
    "EgoSampler",
    "PaperSampling",
    "PeopleSampler",
    "PersistentMotion",
    "PersistentSampling",
    "VelocityEgoSampling",
]

#: The built-in people-motion samplers by the name of the run configuration's ``[filter] motion_model`` key.
PEOPLE_SAMPLERS: dict[str, type[PaperSampling] | type[PersistentSampling]] = {
    "paper": PaperSampling,
    "persistent": PersistentSampling,
}
