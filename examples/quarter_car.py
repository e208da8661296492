"""Simulate a quarter car with the harvester, without and with friction.

The shipped problem file ``quarter_car_class_c`` (passenger car, the paper's prototype at
47 ohm, ISO 8608 class C at 100 km/h) is simulated in the time domain with its friction
and without it; the frictionless run is checked against the exact frequency-domain path,
and the frequency path then evaluates a thousand load resistances at once. Runs in a few
seconds.

    python examples/quarter_car.py
"""

from dataclasses import replace

import numpy as np

from ehsa_opt.datasets.problem_file import load_problem
from ehsa_opt.vehicle.frequency_path import linear_metrics
from ehsa_opt.vehicle.simulate import simulate_quarter_car


def main() -> None:
    prob = load_problem("quarter_car_class_c")
    road = replace(prob.road, length_m=500.0)  # a shorter road than the file's 1 km
    print(f"quarter_car_class_c: class {road.iso_class} road at {road.speed_km_per_h} km/h, {road.length_m} m")

    runs = {}
    for label, friction in (("with friction", prob.friction), ("frictionless", None)):
        sim = simulate_quarter_car(prob.vehicle, prob.harvester, friction, road,
                                   settle_s=prob.simulation.settle_s)
        assert sim.success, sim.message
        runs[label] = m = sim.metrics_of(0)
        print(f"  {label:14s} power {m['power_W']:6.1f} W  efficiency {100 * m['efficiency']:5.1f} %"
              f"  comfort {m['comfort']:.4f}  road holding {m['road_holding']:.4f}"
              f"  energy residual {100 * m['energy_residual']:+.3f} %")

    # the exact frequency-domain path (frictionless, linear) on the same road statistics
    h = prob.harvester
    design = {"load_ohm": h.load_ohm, "lead_mm_per_rev": h.lead_mm_per_rev,
              "total_inertia_gcm2": h.motor_inertia_gcm2 + h.screw_inertia_gcm2,
              "speed_constant_rpm_per_V": 60.0 / (2 * np.pi * h.voltage_constant_Vs_per_rad)}
    exact = linear_metrics(prob.vehicle, road, design)
    td = runs["frictionless"]["power_W"]
    print(f"  frequency path: power {float(exact['power_W']):6.1f} W (time domain, one 500 m road:"
          f" {td:.1f} W, {100 * (td / float(exact['power_W']) - 1):+.1f} %)")

    # a thousand designs at once: the load that harvests most within a comfort limit.
    # (Unconstrained, power grows towards the road's input as the damping vanishes, with
    # an unbounded stroke and comfort: an undamped design is no design.)
    loads = np.geomspace(1.0, 1e4, 1000)
    many = linear_metrics(prob.vehicle, road, {**design, "load_ohm": loads})
    comfort_limit = 0.30  # alpha = rms(W_k-weighted body acceleration) / g
    ok = (many["comfort"] <= comfort_limit) & (many["road_holding"] < 1.0)
    k = int(np.argmax(np.where(ok, many["power_W"], -np.inf)))
    print(f"  best load with comfort <= {comfort_limit}: {loads[k]:.1f} ohm, "
          f"{many['power_W'][k]:.1f} W, comfort {many['comfort'][k]:.4f} (frictionless)")


if __name__ == "__main__":
    main()
