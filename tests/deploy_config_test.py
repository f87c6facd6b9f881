"""The deployment's monitoring files name only metrics the server exports.

Every metric in the alert rules and the Grafana dashboard must be one that
server/metrics.cc registers (or Prometheus' own `up`, or the Redis
exporter's `redis_up`), the dashboard must be Grafana JSON with a Prometheus
target per panel, and the rules must cover replica down, error ratio, p95
latency and Redis down.
"""

import json
import os
import re
import sys
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXTERNAL = {"up", "redis_up"}


def exported():
    src = open(os.path.join(ROOT, "server", "metrics.cc")).read()
    names = set(re.findall(r'\.Name\("([a-z_]+)"\)', src))
    # Histograms also export _bucket, _sum and _count.
    return names | {n + s for n in names for s in ("_bucket", "_sum", "_count")}


def metrics_in(expr):
    words = set(re.findall(r"\b([a-z_][a-z0-9_]*)\b(?=\s*[{\[)]|\s*$|\s*[=<>])",
                           expr))
    return {w for w in words if w.startswith(("meshgauge_", "redis_")) or w == "up"}


class DeployConfigTest(unittest.TestCase):
    def test_alert_rules_use_exported_metrics(self):
        text = open(os.path.join(ROOT, "deploy", "prometheus", "alerts.yml")).read()
        exprs = re.findall(r"expr: \|?\n?((?:.+\n)+?)\s+for:", text)
        self.assertGreaterEqual(len(exprs), 5)
        known = exported() | EXTERNAL
        for e in exprs:
            used = metrics_in(e)
            self.assertTrue(used, e)
            self.assertLessEqual(used, known, e)
        for alert in ("MeshgaugeReplicaDown", "MeshgaugeErrorRatio",
                      "MeshgaugeLatencyP95", "MeshgaugeRedisDown"):
            self.assertIn(f"alert: {alert}", text)

    def test_dashboard_is_grafana_json_with_exported_metrics(self):
        dash = json.load(open(os.path.join(
            ROOT, "deploy", "grafana", "meshgauge-dashboard.json")))
        self.assertEqual(dash["uid"], "meshgauge")
        self.assertGreaterEqual(len(dash["panels"]), 6)
        known = exported() | EXTERNAL
        for p in dash["panels"]:
            self.assertTrue(p["targets"], p["title"])
            for t in p["targets"]:
                used = metrics_in(t["expr"])
                self.assertTrue(used, t["expr"])
                self.assertLessEqual(used, known, t["expr"])


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]])
