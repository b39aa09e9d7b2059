"""Parameter schema of the ``plant`` node (pure: no rclpy), for the node, scenarios and cosim.

Defaults: the BLDC motor of 000 Appendix A (``motors/ozturk_bldc.yaml``) on a six-switch
inverter with the device drops of 001 Table IV, fed by an ideal 40*sqrt(2) V source. Held
parameters (``runtime=False``) change only while the simulation is held. Motor files
(``motors/*.yaml``) hold a ``parameters:`` mapping of these names: :func:`plant_params` merges
one before its overrides, :func:`effective_params` applies ``motor.file`` to a snapshot.
"""
from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any, Iterable, Mapping

from drive_common import file_cache
from drive_common.parameters import ParameterError, ParameterSpec, schema
from drive_common.telemetry import TELEMETRY_PARAMETERS

from .core.lockstep import ticks_of

MOTORS_DIR = Path(__file__).resolve().parent.parent / 'motors'
"""Motor files in the source tree (the symlink install points back here)."""

# 000 Appendix A: lambda_f = 0.1146 Wb is the line-to-line peak per electrical rad/s; the phase
# flat top is lambda_f / 2 (test_motor_files.py: T = 2 p K I = 1.28352 N m at 5.6 A).
OZTURK_K_PHASE = 0.1146 / 2.0

MOTOR_FILE_EXTRAS = ('protection.peak_current',)
"""Non-``motor.*`` names a motor file may set (motor ratings)."""

_S = ParameterSpec
PLANT_SPECS = (
    # ---- time and lockstep (held) ----
    _S('base_tick', 25e-6, 'plant base tick T_s: sample period of the time master',
       's', 1e-7, 1e-2, runtime=False),
    _S('integration.max_step', 25e-6, 'largest inner integration step (events are located inside it)',
       's', 1e-9, 1e-2, runtime=False),
    _S('dtc_period', 25e-6, 'DTC controller period, integer multiple of base_tick (0 = no DTC controller)',
       's', 0.0, 1.0, runtime=False),
    _S('pfc_period', 12.5e-6, 'PFC controller period, integer multiple of base_tick',
       's', 0.0, 1.0, runtime=False),
    _S('pfc_enabled', False, 'wait for a PFC controller (needs the front end)', runtime=False),
    _S('state_period', 0.0, 'plant/state publishing period (0 = every DTC sample)', 's', 0.0, 1.0,
       runtime=False),
    _S('clock_period', 1e-3, '/clock publishing period (0 = with every plant/state)', 's', 0.0, 1.0,
       runtime=False),
    _S('computation_delay', False, 'apply each command one controller sample late, as a DSP does',
       runtime=False),
    _S('pipelined', True, 'with computation_delay: publish the next measurement and integrate '
       'while the controllers compute (same results as waiting for each reply in turn, '
       'false); no effect without computation_delay', runtime=False),
    _S('command_timeout', 5.0, 'wall-clock wait for a due command before the safe state', 's',
       1e-3, 600.0),
    _S('startup_timeout', 120.0, 'wall-clock wait, at the start of a run, for each controller '
       'due in it to match and answer its first measurement (then the run fails)', 's',
       1e-3, 3600.0),
    _S('run_until', 0.0, 'advance to this sim time at start-up without a Run goal (0 = wait)', 's',
       0.0, 1e6),
    # ---- motor (held) ----
    _S('motor.file', '', 'motor data file (name in motors/ or a path): gives the motor.* values '
       'that are not set explicitly (explicit values override the file)', runtime=False),
    _S('motor.pole_pairs', 2, 'pole pairs p (000 App. A: 4 poles)', '', 1, 64, runtime=False),
    _S('motor.resistance', 0.315, 'phase winding resistance R_s', 'ohm', 1e-6, 100.0, runtime=False),
    _S('motor.self_inductance', 1.4e-3, 'phase self inductance L_s', 'H', 1e-7, 1.0, runtime=False),
    _S('motor.mutual_inductance', 0.3125e-3, 'mutual inductance M (the circuit uses L - M)', 'H',
       0.0, 1.0, runtime=False),
    _S('motor.inertia', 2.0e-4, 'rotor + coupling inertia J (assumed: not in 000)', 'kg m^2',
       1e-8, 100.0, runtime=False),
    _S('motor.friction', 3.33e-4, 'viscous friction B of the motor (assumed: not in 000; '
       'ozturk_bldc.yaml gives the reason)', 'N m s/rad', 0.0, 10.0, runtime=False),
    _S('motor.backemf.shape', 'trapezoid', 'back-EMF shape', '',
       choices=('trapezoid', 'harmonic', 'sine', 'table'), runtime=False),
    _S('motor.backemf.constant', OZTURK_K_PHASE,
       'phase back-EMF constant K: flat top (trapezoid) or fundamental peak (sine, harmonic), '
       'per electrical rad/s', 'V s/rad', 0.0, 10.0, runtime=False),
    _S('motor.backemf.harmonic_orders', [1.0, 3.0, 5.0], 'harmonic orders n of the harmonic shape',
       '', 1.0, 99.0, runtime=False),
    _S('motor.backemf.harmonic_coefficients', [1.0, 0.2222222222222222, 0.04],
       'sine amplitudes of the harmonic orders, per unit of K (000 non-ideal: trapezoid 1st/3rd/5th)',
       '', -10.0, 10.0, runtime=False),
    _S('motor.backemf.table_file', '', 'back-EMF table CSV (docs/architecture.md format) for shape=table',
       runtime=False),
    _S('motor.backemf.phase_gain', [1.0, 1.0, 1.0], 'per-phase back-EMF scale (imbalance, 001 Table VII)',
       '', 0.0, 10.0, length=3, runtime=False),
    _S('motor.backemf.lut_points', 3072, 'back-EMF lookup-table points per electrical cycle '
       '(multiple of 12 keeps trapezoid corners exact)', '', 12, 1_000_000, runtime=False),
    _S('motor.initial_angle', 0.0, 'initial mechanical rotor angle', 'rad', -1e6, 1e6, runtime=False),
    _S('motor.initial_speed', 0.0, 'initial mechanical speed', 'rad/s', -1e5, 1e5, runtime=False),
    # ---- inverter ----
    _S('inverter.topology', 6, 'six-switch or four-switch inverter', '', choices=(4, 6), runtime=False),
    _S('inverter.midpoint_phase', 'c', 'four-switch: phase tied to the capacitor midpoint '
       '(c for 000 ch. IV, a for 001)', '', choices=('a', 'b', 'c'), runtime=False),
    _S('inverter.v_ce', 0.9, 'switch on-state threshold V_CE (default 001 Table IV; 0 = ideal)', 'V',
       0.0, 10.0),
    _S('inverter.v_d', 1.25, 'diode forward drop V_d (default 001 Table IV; 0 = ideal)', 'V', 0.0, 10.0),
    _S('inverter.r_on', 0.075, 'on-state resistance of a conducting device (default 001 Table IV; '
       '0 = ideal)', 'ohm', 0.0, 10.0),
    _S('inverter.dead_time', 0.0, 'both switches of a leg off after each gate transition', 's',
       0.0, 1e-3, runtime=False),
    _S('inverter.shoot_through', 'safe_state', 'a command with both switches of a leg on is a '
       'shoot-through fault (reported with the leg); safe_state: all switches off until '
       'plant/reset_protection; interlock: that leg off, the run goes on', '',
       choices=('safe_state', 'interlock')),
    # ---- DC link ----
    _S('dc_link.mode', 'ideal', 'ideal: stiff source (stiff midpoint); split_capacitors: stiff source '
       'across C_upper + C_lower, midpoint drifts; current_fed: capacitors fed by a source current',
       '', choices=('ideal', 'split_capacitors', 'current_fed'), runtime=False),
    _S('dc_link.voltage', 40.0 * math.sqrt(2.0), 'DC source voltage (000: 40*sqrt(2) V; 001: 70 V)',
       'V', 0.0, 2000.0, runtime=False),
    _S('dc_link.upper_capacitance', 270e-6, 'upper split capacitor C3 (000 ch. III)', 'F', 1e-9, 10.0,
       runtime=False),
    _S('dc_link.lower_capacitance', 270e-6, 'lower split capacitor C4 (000 ch. III)', 'F', 1e-9, 10.0,
       runtime=False),
    _S('dc_link.initial_midpoint', 0.5, 'initial lower capacitor voltage per unit of dc_link.voltage',
       '', 0.0, 1.0, runtime=False),
    _S('dc_link.source_current', 0.0, 'current_fed mode: source current into the positive rail', 'A',
       -1000.0, 1000.0),
    # ---- boost PFC front end (000 ch. III, Fig. 3.1; core/front_end.py) ----
    _S('front_end.enabled', False, 'feed the DC link from the grid through the EMI filter, diode '
       'bridge and boost stage (needs dc_link.mode current_fed; dc_link.voltage is then the '
       'initial capacitor-string voltage)', runtime=False),
    _S('front_end.line_voltage', 25.4, 'grid voltage, RMS (000 Figs. 3.5-3.6: 25.4 V; Fig. 3.4: '
       '64.53 V)', 'V', 0.0, 1000.0),
    _S('front_end.line_frequency', 60.0, 'grid frequency', 'Hz', 1.0, 1000.0, runtime=False),
    _S('front_end.line_phase', 0.0, 'grid voltage phase at t = 0: v_g = sqrt(2) V sin(2 pi f t + '
       'phase)', 'rad', -2.0 * math.pi, 2.0 * math.pi),
    _S('front_end.line_resistance', 0.0, 'supply (source) series resistance, not in 000: 0 = stiff '
       'grid', 'ohm', 0.0, 100.0),
    _S('front_end.line_inductance', 0.0, 'supply (source) series inductance, not in 000: 0 = stiff '
       'grid', 'H', 0.0, 1.0, runtime=False),
    _S('front_end.filter.enabled', True, 'EMI filter C1 - L1, L2 - C2 between grid and bridge '
       '(000 ch. III)', runtime=False),
    _S('front_end.filter.inductance', 10e-6, 'EMI filter inductance L1 = L2, one per line conductor '
       '(000: 10 uH)', 'H', 1e-9, 1.0, runtime=False),
    _S('front_end.filter.capacitance', 1e-6, 'EMI filter capacitance C1 = C2 (000: 1 uF)', 'F',
       1e-12, 1.0, runtime=False),
    _S('front_end.filter.resistance', 0.05, 'series resistance of each EMI filter inductor (assumed)',
       'ohm', 0.0, 100.0),
    _S('front_end.boost.inductance', 1e-3, 'boost inductor L3 (000: 1 mH)', 'H', 1e-7, 1.0,
       runtime=False),
    _S('front_end.boost.resistance', 0.1, 'boost inductor series resistance (assumed)', 'ohm',
       0.0, 100.0),
    _S('front_end.boost.switch_resistance', 0.07, 'boost switch on-state resistance (FET47N60C3: '
       '0.07 ohm)', 'ohm', 0.0, 100.0),
    _S('front_end.boost.diode_drop', 1.0, 'boost diode forward drop (STTH8R06D: about 1 V)', 'V',
       0.0, 10.0),
    _S('front_end.bridge.diode_drop', 0.8, 'forward drop of each bridge diode (two conduct)', 'V',
       0.0, 10.0),
    _S('front_end.pwm_frequency', 80e3, 'boost PWM frequency, carrier locked to sim time (000: '
       '80 kHz)', 'Hz', 1.0, 10e6, runtime=False),
    _S('front_end.pwm_carrier', 'triangle', 'triangle: on-time centred on the period boundary (a '
       'sample at t_k reads the average current); sawtooth: on for [0, d T)', '',
       choices=('triangle', 'sawtooth'), runtime=False),
    _S('front_end.over_current_limit', 8.0, 'boost inductor over-current: switch opened at this '
       'current (000: 8 A); 0 = disabled', 'A', 0.0, 1000.0),
    _S('front_end.over_voltage_limit', 140.0, 'boost output over-voltage: switch held off above '
       'this link voltage (000: 140 V); 0 = disabled', 'V', 0.0, 2000.0),
    _S('front_end.protection_latched', False, 'boost protections stay latched until a protection '
       'reset (false: cycle by cycle, released once back within the limit)'),
    _S('front_end.max_step', 1e-6, 'largest front-end inner step with the EMI filter (resolves the '
       'L1 + L2 / C2 resonance)', 's', 1e-9, 1e-3, runtime=False),
    # ---- load machine (runtime) ----
    _S('load.mode', 'torque', 'load machine: constant torque, viscous, or dynamometer holding a speed',
       '', choices=('torque', 'viscous', 'dynamometer')),
    _S('load.torque', 0.0, 'constant load torque against positive rotation', 'N m', -1000.0, 1000.0),
    _S('load.viscous', 0.0, 'viscous load coefficient (T_L = b w)', 'N m s/rad', 0.0, 1000.0),
    _S('load.speed', 0.0, 'dynamometer mechanical speed', 'rad/s', -1e5, 1e5),
    # ---- sensors (runtime, except the seed) ----
    _S('sensors.current_count', 3, 'phase current sensors: 2 (a, b; c = NaN) or 3', '',
       choices=(2, 3)),
    _S('sensors.current_offset', [0.0, 0.0, 0.0], 'current sensor offsets', 'A', -100.0, 100.0,
       length=3),
    _S('sensors.current_gain_error', [0.0, 0.0, 0.0], 'current sensor gain errors (measured = (1+g) i)',
       '', -0.5, 0.5, length=3),
    _S('sensors.current_noise', 0.0, 'current sensor noise standard deviation', 'A', 0.0, 100.0),
    _S('sensors.voltage_offset', 0.0, 'DC and midpoint voltage sensor offset', 'V', -100.0, 100.0),
    _S('sensors.voltage_gain_error', 0.0, 'DC and midpoint voltage sensor gain error', '', -0.5, 0.5),
    _S('sensors.voltage_noise', 0.0, 'voltage sensor noise standard deviation', 'V', 0.0, 100.0),
    _S('sensors.speed_noise', 0.0, 'speed sensor noise standard deviation', 'rad/s', 0.0, 1e4),
    _S('sensors.encoder_pulses', 2048, 'encoder pulses per revolution (x4 quadrature counts)', '',
       1, 1_000_000, runtime=False),
    _S('sensors.encoder_offset', 0.0, 'encoder zero offset (electrical angle error)', 'rad',
       -math.pi, math.pi),
    _S('sensors.seed', 0, 'seed of the sensor-noise generator (numpy Generator, deterministic)', '',
       0, 2**63 - 1, runtime=False),
    # ---- protection ----
    _S('protection.peak_current', 24.0, 'motor peak-current trip (000 App. A: 24 A); 0 = disabled',
       'A', 0.0, 10000.0),
)


def _cross_checks(p: Mapping[str, Any]) -> None:
    """Checks that involve several parameters; raise ParameterError with the reason."""
    tick = p['base_tick']
    ticks_of(p['dtc_period'], tick, 'dtc_period')
    if p['pfc_enabled']:
        ticks_of(p['pfc_period'], tick, 'pfc_period')
    if p['integration.max_step'] > tick * (1 + 1e-12):
        raise ParameterError(f"integration.max_step: {p['integration.max_step']} s exceeds base_tick {tick} s")
    if p['inverter.dead_time'] >= tick:
        raise ParameterError(f"inverter.dead_time: {p['inverter.dead_time']} s must be shorter than "
                             f'base_tick {tick} s')
    if p['motor.mutual_inductance'] >= p['motor.self_inductance']:
        raise ParameterError('motor.mutual_inductance: must be below motor.self_inductance '
                             '(the phase circuit inductance L - M must be positive)')
    orders = p['motor.backemf.harmonic_orders']
    coeffs = p['motor.backemf.harmonic_coefficients']
    if len(orders) != len(coeffs):
        raise ParameterError(f'motor.backemf.harmonic_coefficients: {len(coeffs)} values for '
                             f'{len(orders)} harmonic_orders')
    if any(o != int(o) for o in orders):
        raise ParameterError('motor.backemf.harmonic_orders: orders must be whole numbers')
    if p['front_end.enabled'] and p['dc_link.mode'] != 'current_fed':
        raise ParameterError(f"front_end.enabled: needs dc_link.mode current_fed (the front end "
                             f"feeds the capacitor string), not {p['dc_link.mode']!r}")
    if p['pfc_enabled'] and not p['front_end.enabled']:
        raise ParameterError('pfc_enabled: a PFC controller needs the boost front end '
                             '(front_end.enabled true)')
    if p['motor.backemf.shape'] == 'table' and not p['motor.backemf.table_file']:
        raise ParameterError('motor.backemf.table_file: required when motor.backemf.shape is table')


PLANT_SCHEMA = schema(PLANT_SPECS + TELEMETRY_PARAMETERS, _cross_checks)
"""The plant node's parameters (declared by the ROS wrapper, used by PlantCore)."""


def motor_file_path(name: str) -> Path:
    """Path of a motor file: a path, or a name (with or without .yaml) in ``motors/``."""
    path = Path(name)
    if path.suffix in ('.yaml', '.yml') and path.exists():
        return path
    candidates = [MOTORS_DIR / name, MOTORS_DIR / f'{name}.yaml']
    try:  # installed share directory, when running from an install space
        from ament_index_python.packages import get_package_share_directory  # noqa: PLC0415
        share = Path(get_package_share_directory('bldc_plant_sim')) / 'motors'
        candidates += [share / name, share / f'{name}.yaml']
    except Exception:  # noqa: BLE001 - no ament index: source tree only
        pass
    for cand in candidates:
        if cand.is_file():
            return cand
    raise ParameterError(f'motor.file: no motor file {name!r} (looked in {MOTORS_DIR})')


def load_motor_file(name: str) -> dict[str, Any]:
    """A copy of the ``parameters:`` mapping of a motor file, each value checked by the schema
    (ParameterError names the file and key); read once per file version (drive_common.file_cache)."""
    path = motor_file_path(name)
    return copy.deepcopy(file_cache.from_file('motor_file', path, lambda: _read_motor_file(path)))


def _read_motor_file(path: Path) -> dict[str, Any]:
    import yaml  # noqa: PLC0415

    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ParameterError(f'motor.file: cannot read {path}: {exc}') from exc
    params = data.get('parameters') if isinstance(data, dict) else None
    if not isinstance(params, dict):
        raise ParameterError(f'motor.file: {path} has no "parameters:" mapping')
    unknown = sorted(set(params) - set(PLANT_SCHEMA.names()))
    if unknown:
        raise ParameterError(f'motor.file: {path}: unknown parameter(s) ' + ', '.join(unknown))
    foreign = sorted(n for n in params if not n.startswith('motor.') and n not in MOTOR_FILE_EXTRAS
                     or n == 'motor.file')
    if foreign:
        raise ParameterError(f'motor.file: {path}: not motor data: ' + ', '.join(foreign))
    clean = {}
    for key, value in params.items():
        try:
            clean[key] = PLANT_SCHEMA[key].check(value)
        except ParameterError as exc:
            raise ParameterError(f'motor.file: {path}: {exc}') from exc
    table = clean.get('motor.backemf.table_file')
    if table and not Path(table).is_absolute():
        clean['motor.backemf.table_file'] = str((path.parent / table).resolve())
    return clean


def _cross_check_with_file(values: dict[str, Any], file_name: str) -> dict[str, Any]:
    """Schema cross-checks of a merged snapshot; an error names the motor file that fed it."""
    try:
        return PLANT_SCHEMA.validate_changes(values, {}, running=False)
    except ParameterError as exc:
        if not file_name:
            raise
        raise ParameterError(f'{exc} (motor.file {motor_file_path(file_name)} with the '
                             'explicit parameters)') from exc


def effective_params(snapshot: Mapping[str, Any], previous: Mapping[str, Any] | None = None, *,
                     explicit: Iterable[str] = (),
                     previous_effective: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The parameter values the plant uses for a requested snapshot (``motor.file`` applied).

    previous: the snapshot requested before (None: start-up); explicit: names set whatever their
    value; previous_effective: the values used before (default ``previous``). The rule:
    docs/models.md "Motor files". A full validated snapshot; ParameterError names the file.
    """
    defaults = PLANT_SCHEMA.defaults()
    requested = PLANT_SCHEMA.validate_changes(defaults, snapshot, running=False)
    start = previous is None
    before = defaults if start else PLANT_SCHEMA.validate_changes(defaults, previous, running=False)
    used_before = before if previous_effective is None else dict(previous_effective)
    explicit = set(explicit)
    file_name = requested['motor.file']
    file_changed = start or file_name != before['motor.file']
    new_file = load_motor_file(file_name) if file_name else {}
    old_file = (load_motor_file(before['motor.file'])
                if file_changed and before['motor.file'] and not start else {})
    values = dict(requested)
    for name in set(new_file) | set(old_file):
        if name in explicit or requested[name] != before[name]:
            continue                                    # set in this snapshot: overrides the file
        if file_changed:
            values[name] = new_file.get(name, defaults[name])
        else:
            values[name] = used_before.get(name, requested[name])
    return _cross_check_with_file(values, file_name)


def plant_params(motor: str | None = None, **overrides: Any) -> dict[str, Any]:
    """A validated snapshot: defaults, a motor file, then overrides (dotted names as
    ``**{'load.torque': 0.3}``); ``motor.file`` stays empty (its values are in the snapshot)."""
    unknown = sorted(set(overrides) - set(PLANT_SCHEMA.names()))
    if unknown:
        raise ParameterError('unknown parameter(s): ' + ', '.join(unknown))
    values = PLANT_SCHEMA.defaults()
    if motor:
        values.update(load_motor_file(motor))
    values = _cross_check_with_file(values, motor or '')
    return PLANT_SCHEMA.validate_changes(values, overrides, running=False)
