"""The engine list of the Yade reference scripts (run under ``yade -x``, imported from their folder).

ForceResetter, InsertionSortCollider over spheres and facets, an InteractionLoop with the ScGeom6D geometries,
Ip2_CohFrictMat_CohFrictMat_CohFrictPhys (label ``ip2``) and Law2_ScGeom6D_CohFrictPhys_CohesionMoment in its
incremental form (label ``law``), NewtonIntegrator (label ``newton``) and a recorder PyRunner calling ``record()``
every ``period`` steps, its first call at step ``period - 1`` (label ``recorder``; see README.md, "Recording
convention"); ``extra`` engines follow it.
"""

from yade.wrapper import (
    Bo1_Facet_Aabb,
    Bo1_Sphere_Aabb,
    ForceResetter,
    Ig2_Facet_Sphere_ScGeom6D,
    Ig2_Sphere_Sphere_ScGeom6D,
    InsertionSortCollider,
    InteractionLoop,
    Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
    Law2_ScGeom6D_CohFrictPhys_CohesionMoment,
    NewtonIntegrator,
    PyRunner,
)


def cohfrict_engines(*, gravity, damping, period, set_cohesion_now=False, cohesion_on_new_contacts=False,
                     always_use_moment_law=False, extra=()):
    """The engines: gravity [m/s^2] (3,), NewtonIntegrator's local damping [-], the recorder's period [steps]."""
    return [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D(), Ig2_Facet_Sphere_ScGeom6D()],
                        [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(label='ip2', setCohesionNow=set_cohesion_now,
                                                                  setCohesionOnNewContacts=cohesion_on_new_contacts)],
                        [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(label='law', useIncrementalForm=True,
                                                                   always_use_moment_law=always_use_moment_law)]),
        NewtonIntegrator(gravity=gravity, damping=damping, label='newton'),
        PyRunner(iterPeriod=period, firstIterRun=period - 1, command='record()', label='recorder'),
        *extra,
    ]
