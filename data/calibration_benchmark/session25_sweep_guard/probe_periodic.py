import sys
sys.path.insert(0, ".")
from plant.calibration import blind_records as B, loop
from plant.calibration.fit import prepare
from plant.calibration.io import Record
for s in [3, 47, 107, 123, 136, 144]:
    r = B.make_record(s)
    rec = Record(name=f"b{s}", t_s=r.t_s, position=r.position_rad, torque=r.torque_nm)
    f, share, k = loop.periodic_motion(prepare(rec))
    print(s, r.hidden, r.meta["trajectory"], f, round(share, 3), k)
