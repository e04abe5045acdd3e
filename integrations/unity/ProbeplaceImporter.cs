// ProbeplaceImporter.cs: a Unity editor script that reads the probes of a
// probeplace run (probes.unity.json, written by
// `probeplace export DIR --format unity`) into a LightProbeGroup.
//
// Install: copy this file into any `Editor` folder of your Unity project
// (for example Assets/Editor/ProbeplaceImporter.cs). It adds the menu item
// Tools > probeplace > Import Light Probes…, which asks for a
// probes.unity.json and creates a GameObject "probeplace probes" holding a
// LightProbeGroup with one light probe per probe, at the world origin with
// no rotation or scale. Then bake lighting as usual (Window > Rendering >
// Lighting > Generate Lighting): Unity bakes its light probes at the
// positions probeplace chose. docs/engines.md has the whole workflow.
//
// Axes. probeplace's world frame is right-handed with +Y up (the OBJ's
// frame, scaled by the config's `scale`, turned Y-up for `up: Z` files).
// Unity's is left-handed with +Y up and +Z forward. The importer converts a
// position (x, y, z) to Unity's (-x, y, z), negating x as Unity's own OBJ,
// FBX and glTF importers do, so the probes line up with the scene imported
// into Unity from its OBJ (at the import scale that matches `scale`) or
// from probeplace's probes.glb.
//
// The file's fields are declared by ProbesUnityFile below, one for one with
// probes.unity.schema.json beside this script; probeplace's test suite
// checks that the files it writes match the schema and that this class
// declares the schema's fields with matching types.

using System;
using System.IO;
using UnityEditor;
using UnityEngine;
using UnityEngine.Rendering;

namespace Probeplace
{
    /// <summary>The contents of probes.unity.json (schema: probes.unity.schema.json).</summary>
    [Serializable]
    public class ProbesUnityFile
    {
        public string format;
        public int version;
        public string tool;
        public string config_hash;
        public string scene_hash;
        public string seed;
        public string method;
        public string frame;
        public int count;
        public string sh_convention;
        public float[] positions;
        public float[] sh;
    }

    /// <summary>Reads probes.unity.json into a LightProbeGroup.</summary>
    public static class ProbeplaceImporter
    {
        /// <summary>The format and version this importer reads.</summary>
        public const string Format = "probeplace.unity";
        public const int Version = 1;

        [MenuItem("Tools/probeplace/Import Light Probes…")]
        static void ImportFromMenu()
        {
            string path = EditorUtility.OpenFilePanel("probeplace probes.unity.json", "", "json");
            if (string.IsNullOrEmpty(path))
            {
                return;
            }
            try
            {
                LightProbeGroup group = Import(path);
                Selection.activeGameObject = group.gameObject;
            }
            catch (Exception e)
            {
                EditorUtility.DisplayDialog("probeplace", e.Message, "OK");
            }
        }

        /// <summary>
        /// Reads the file at <paramref name="path"/> and creates a GameObject
        /// with a LightProbeGroup holding its probes, converted to Unity's
        /// frame; undoable. Throws with a one-line message on a file that is
        /// not a probeplace export of this version.
        /// </summary>
        public static LightProbeGroup Import(string path)
        {
            ProbesUnityFile file = Read(File.ReadAllText(path), path);
            var probes = new Vector3[file.count];
            for (int i = 0; i < file.count; i++)
            {
                probes[i] = ToUnity(file.positions[3 * i], file.positions[3 * i + 1], file.positions[3 * i + 2]);
            }
            var go = new GameObject("probeplace probes");
            Undo.RegisterCreatedObjectUndo(go, "Import probeplace light probes");
            var group = go.AddComponent<LightProbeGroup>();
            group.probePositions = probes;
            if (file.count < 4)
            {
                Debug.LogWarning($"probeplace: {path} has {file.count} probes; Unity interpolates light probes over tetrahedra and needs at least 4");
            }
            Debug.Log($"probeplace: {file.count} light probes of {file.method} ({file.tool}, config {file.config_hash}, scene {file.scene_hash}, seed {file.seed}) from {path}");
            return group;
        }

        [MenuItem("Tools/probeplace/Apply Baked SH…")]
        static void ApplyFromMenu()
        {
            string path = EditorUtility.OpenFilePanel("probeplace probes.unity.json (of a bake)", "", "json");
            if (string.IsNullOrEmpty(path))
            {
                return;
            }
            try
            {
                int n = ApplyBakedSH(path);
                EditorUtility.DisplayDialog("probeplace", $"{n} baked light probes now hold probeplace's light", "OK");
            }
            catch (Exception e)
            {
                EditorUtility.DisplayDialog("probeplace", e.Message, "OK");
            }
        }

        /// <summary>
        /// Replaces the light of the scene's baked light probes
        /// (LightmapSettings.lightProbes, made by Unity's bake of the group
        /// Import created) with the file's SH: each baked probe takes the
        /// file's probe at its position (within a millimetre), since Unity
        /// orders bakedProbes its own way. Returns how many were set;
        /// throws when the file holds no SH or a baked probe has no match.
        /// </summary>
        public static int ApplyBakedSH(string path)
        {
            ProbesUnityFile file = Read(File.ReadAllText(path), path);
            if (file.sh == null || file.sh.Length == 0)
            {
                throw new InvalidDataException($"{path}: holds no SH; export it from a bake (probeplace bake, then export --format unity)");
            }
            LightProbes probes = LightmapSettings.lightProbes;
            if (probes == null || probes.count == 0)
            {
                throw new InvalidOperationException("no baked light probes: import the probes, bake the lighting once, then apply");
            }
            Vector3[] baked = probes.positions;
            SphericalHarmonicsL2[] sh = probes.bakedProbes;
            for (int j = 0; j < baked.Length; j++)
            {
                int match = -1;
                for (int i = 0; i < file.count; i++)
                {
                    Vector3 p = ToUnity(file.positions[3 * i], file.positions[3 * i + 1], file.positions[3 * i + 2]);
                    if ((p - baked[j]).sqrMagnitude < 1e-6f)
                    {
                        match = i;
                        break;
                    }
                }
                if (match < 0)
                {
                    throw new InvalidDataException($"{path}: baked probe {j} at {baked[j]} is not one of the file's probes");
                }
                for (int c = 0; c < 3; c++)
                {
                    for (int k = 0; k < 9; k++)
                    {
                        sh[j][c, k] = file.sh[27 * match + 9 * c + k];
                    }
                }
            }
            probes.bakedProbes = sh;
            EditorUtility.SetDirty(probes);
            return baked.Length;
        }

        /// <summary>Parses and checks the text of a probes.unity.json.</summary>
        public static ProbesUnityFile Read(string json, string path)
        {
            ProbesUnityFile file = JsonUtility.FromJson<ProbesUnityFile>(json);
            if (file == null || file.format != Format)
            {
                throw new InvalidDataException($"{path}: not a probeplace probes.unity.json (write one with probeplace export DIR --format unity)");
            }
            if (file.version != Version)
            {
                throw new InvalidDataException($"{path}: version {file.version}; this importer reads version {Version}");
            }
            if (file.positions == null || file.count < 1 || file.positions.Length != 3 * file.count)
            {
                throw new InvalidDataException($"{path}: count {file.count} does not match {file.positions?.Length ?? 0} position numbers");
            }
            if (file.sh != null && file.sh.Length != 0 && file.sh.Length != 27 * file.count)
            {
                throw new InvalidDataException($"{path}: count {file.count} does not match {file.sh.Length} SH numbers (27 a probe)");
            }
            return file;
        }

        /// <summary>
        /// probeplace's world frame (right-handed, +Y up) to Unity's
        /// (left-handed, +Y up): x negated.
        /// </summary>
        public static Vector3 ToUnity(float x, float y, float z)
        {
            return new Vector3(-x, y, z);
        }
    }
}
